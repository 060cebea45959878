"""Every code block of README.md and of the docs pages (docs/, the site ``mkdocs.yml`` builds) runs as written.

Each ```bash / ```python block is one test, run in one scratch folder in the README's order and then
page by page in the order of ``mkdocs.yml``'s ``nav`` (so a block may use what an earlier one wrote,
as a reader following the page would), with the checkout's
top-level files and folders linked into it (``python benchmarks/env.py`` works) and the test's
own Python first on PATH. A python block is saved as a script and run with ``python script.py``,
exactly as a reader pasting it into a file would. A block is skipped only when the line right
before its opening fence says why::

    <!-- readme-test: skip (needs a display) -->

The skip reasons allowed are few (below): a display, an optional extra or a package install, a run
of minutes (whose short form is a block beside it or a test), or the setup and test commands.

No block reaches a package index from the suite: a ``pip install -e ".[extra]"`` line (the
Benchmarks block installs OpenCV that way) is not run but checked, each requirement of the named
extras must already be installed here, and the block is skipped naming what is missing otherwise;
a block that installs anything else is skipped. A block is never killed by a wall-clock limit a
loaded machine can reach (``HANG_S`` is only a hang guard).

A block that needs the ``gpu`` extra says so on the line before it::

    <!-- readme-test: needs the gpu extra -->

and runs wherever that extra is installed (CI installs it), skipping with that reason elsewhere: it
counts as a block that runs.

A page may show a block of the README with ``--8<-- "README.md:name"`` (pymdownx.snippets, between the
README's ``[start:name]`` and ``[end:name]`` comments): that block runs once, as the README's. The
README stays short (at most ``README_MAX_LINES``), and every page under docs/ is in the nav.

Each block's outputs (the files it writes in the scratch folder) are compared with the digests of
``tests/data/readme_outputs.json`` (``tests/readme_outputs.py`` says what is compared and how to
regenerate the manifest when a change is intended).
"""

from __future__ import annotations

import importlib.metadata
import importlib.util
import os
import re
import subprocess
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

import pytest
import readme_outputs  # tests/readme_outputs.py

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"
MKDOCS = ROOT / "mkdocs.yml"
README_MAX_LINES = 250
SNIPPET = re.compile(r'^--8<--\s+"(?P<file>[^":]+)(?::(?P<section>[\w-]+))?"\s*$', re.M)
SKIP = re.compile(r"<!--\s*readme-test:\s*skip\s*\((?P<why>[^)]+)\)\s*-->")
NEEDS_GPU = re.compile(r"<!--\s*readme-test:\s*needs the gpu extra\s*-->")
#: what the gpu extra brings (envs.batched_physics.require_gpu_extra imports them)
GPU_MODULES = ("torch", "warp", "mujoco_warp", "skrl")
FENCE = re.compile(r"^```(?P<lang>[A-Za-z0-9_+-]*)\s*$")
LANGS = {"bash": "bash", "sh": "bash", "shell": "bash", "python": "python", "py": "python"}
# what may excuse a block from running, each with a reason a reader accepts
#: a hang guard, never a limit a loaded machine reaches
HANG_S = 3600
PIP_INSTALL = re.compile(r"^\s*(?:python3? -m )?pip3? install\b(?P<args>[^#\n]*)(?:#.*)?$", re.M)
EDITABLE_EXTRAS = re.compile(r"""^(?:-q\s+)?-e\s+["']?\.\[(?P<extras>[A-Za-z0-9_,-]+)\]["']?$""")
ALLOWED_SKIPS = ("needs a display", "serves until Ctrl-C", "needs the rl extra", "installs packages", "minutes", "the test command",
                 "the setup command", "run and checked by tests/")


@dataclass(frozen=True)
class Block:
    line: int  # 1-based line of the opening fence
    lang: str
    code: str
    skip: str | None
    needs_gpu: bool = False
    source: str = "README.md"  # the file, relative to the checkout

    @property
    def id(self) -> str:
        first = next((ln for ln in self.code.splitlines() if ln.strip() and not ln.startswith("#")), "")
        where = "" if self.source == "README.md" else f"{self.source.removeprefix('docs/')}:"
        return f"{where}L{self.line}-{self.lang}-{re.sub(r'[^A-Za-z0-9_.-]+', '_', first)[:40]}"


def readme_blocks(text: str, source: str = "README.md") -> list[Block]:
    """The fenced code blocks of a Markdown text (the file ``source``), with their skip markers."""
    lines = text.splitlines()
    blocks, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if m and m["lang"]:
            j = i + 1
            while j < len(lines) and not lines[j].startswith("```"):
                j += 1
            if j == len(lines):
                raise ValueError(f"{source} line {i + 1}: code block never closed")
            prev = next((lines[k] for k in range(i - 1, -1, -1) if lines[k].strip()), "")
            s = SKIP.search(prev)
            blocks.append(Block(i + 1, m["lang"].lower(), "\n".join(lines[i + 1:j]) + "\n", s["why"] if s else None,
                                bool(NEEDS_GPU.search(prev)), source))
            i = j + 1
        else:
            i += 1
    return blocks


def nav_pages(mkdocs_yml: str) -> list[str]:
    """The pages of ``mkdocs.yml``'s ``nav``, in order (paths under docs/); none without a nav."""
    _, found, nav = mkdocs_yml.partition("\nnav:")
    return re.findall(r"^\s+-\s+(?:[^\n]*?:\s+)?([\w./-]+\.md)\s*$", nav, re.M) if found else []


#: README.md, then the docs pages in the nav's order
SOURCES = ["README.md"] + [f"docs/{p}" for p in nav_pages(MKDOCS.read_text() if MKDOCS.is_file() else "")
                           if (DOCS / p).is_file()]  # a nav entry without its page fails the nav test
BLOCKS = [b for src in SOURCES for b in readme_blocks((ROOT / src).read_text(), src) if b.lang in LANGS]


def _example_names(blocks: list[Block]) -> dict[Block, str]:
    """Each block's name in the outputs manifest: its file and first line, numbered when repeated."""
    names, seen = {}, {}
    for b in blocks:
        name = readme_outputs.example_name(b.source, b.code)
        seen[name] = seen.get(name, 0) + 1
        names[b] = name if seen[name] == 1 else f"{name} (#{seen[name]})"
    return names


EXAMPLES = _example_names(BLOCKS)


def test_readme_has_blocks_and_known_languages():
    every = [b for src in SOURCES for b in readme_blocks((ROOT / src).read_text(), src)]
    assert len(BLOCKS) >= 10
    assert {b.lang for b in every} <= set(LANGS) | {"text", "toml", "json", "csv", ""}, {b.lang for b in every}


def test_readme_skips_are_justified():
    for b in BLOCKS:
        if b.skip is not None:
            assert any(b.skip.startswith(a) for a in ALLOWED_SKIPS), (b.line, b.skip)
            if b.skip.startswith("run and checked by tests/"):  # the named test exists and runs the same command
                path, _, name = b.skip.removeprefix("run and checked by ").split()[0].partition("::")
                test_file = README.parent / path
                assert test_file.is_file() and f"def {name}(" in test_file.read_text(), (b.line, b.skip)
                assert b.code.split()[3] in test_file.read_text(), (b.line, b.skip)  # the subcommand
    # most blocks run: a skip is the exception
    assert sum(b.skip is None for b in BLOCKS) >= 0.6 * len(BLOCKS)


def test_readme_is_short_and_every_docs_page_is_in_the_nav():
    lines = README.read_text().count("\n")
    assert lines <= README_MAX_LINES, f"README.md has {lines} lines (at most {README_MAX_LINES}): move detail to docs/"
    nav = nav_pages(MKDOCS.read_text())
    pages = sorted(str(p.relative_to(DOCS)) for p in DOCS.rglob("*.md"))
    assert len(nav) == len(set(nav)), f"a page is twice in mkdocs.yml's nav: {nav}"
    assert sorted(nav) == pages, (f"docs pages not in mkdocs.yml's nav: {sorted(set(pages) - set(nav))}; "
                                  f"nav entries with no page: {sorted(set(nav) - set(pages))}")


def test_snippets_name_readme_sections():
    """Each ``--8<-- "FILE:section"`` of a page names a file and a section it has (the build checks it
    too, but the suite runs without the docs extra)."""
    readme = README.read_text()
    for src in SOURCES[1:]:
        for m in SNIPPET.finditer((ROOT / src).read_text()):
            target = (ROOT / m["file"]).read_text()
            if m["section"]:
                assert f"[start:{m['section']}]" in target and f"[end:{m['section']}]" in target, (src, m[0])
    assert "[start:quickstart]" in readme and "[start:setup]" in readme


def test_nav_pages_in_order():
    yml = "site_name: x\nnav:\n  - Home: index.md\n  - Part:\n      - One: part/one.md\n      - two.md\n"
    assert nav_pages(yml) == ["index.md", "part/one.md", "two.md"]
    assert nav_pages("site_name: x\n") == []


def test_parser_finds_skip_markers():
    text = "x\n<!-- readme-test: skip (needs a display) -->\n```bash\nrerun a.rrd\n```\n\n```python\nprint(1)\n```\n"
    a, b = readme_blocks(text)
    assert (a.lang, a.skip, a.code, a.line) == ("bash", "needs a display", "rerun a.rrd\n", 3)
    assert (b.lang, b.skip, b.code) == ("python", None, "print(1)\n")
    (c,) = readme_blocks("<!-- readme-test: needs the gpu extra -->\n```python\nimport torch\n```\n")
    assert (c.skip, c.needs_gpu) == (None, True) and not b.needs_gpu


def _requirement_name(req: str) -> str:
    return re.match(r"[A-Za-z0-9_.-]+", req).group(0)


def _missing_for(extras: list[str]) -> list[str]:
    """The requirements of the project's ``extras`` (pyproject.toml) not installed here."""
    optional = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    missing = []
    for extra in extras:
        if extra not in optional:
            missing.append(f"the extra {extra!r} (not in pyproject.toml)")
            continue
        for req in optional[extra]:
            try:
                importlib.metadata.distribution(_requirement_name(req))
            except importlib.metadata.PackageNotFoundError:
                missing.append(req)
    return missing


def without_installs(code: str) -> tuple[str, str | None]:
    """``code`` with its ``pip install -e ".[extras]"`` lines replaced by no-ops when those extras
    are installed here; otherwise (or for any other pip install) a reason to skip the block."""
    def replace(m: re.Match) -> str:
        args = m["args"].strip()
        e = EDITABLE_EXTRAS.match(args)
        if e is None:
            raise LookupError(f"installs packages (pip install {args}), which the suite never does")
        missing = _missing_for(e["extras"].split(","))
        if missing:
            raise LookupError(f"needs {', '.join(missing)} (pip install {args})")
        return f": # pip install {args}: installed here"

    try:
        out = PIP_INSTALL.sub(replace, code)
    except LookupError as why:
        return code, str(why)
    if re.search(r"\bpip3? install\b", out.replace(": # pip install", "")):  # inside a longer command line
        return code, "installs packages (a pip install inside a longer command), which the suite never does"
    return out, None


def test_pip_install_lines_never_run():
    code, why = without_installs('pip install -e ".[test]"   # the test extra\npython -c "print(1)"\n')
    assert why is None and code.startswith(": # pip install") and "print(1)" in code
    assert without_installs("python -m pip install torch\n")[1].startswith("installs packages")
    assert "the extra 'nope'" in without_installs('pip install -e ".[nope]"\n')[1]
    assert without_installs("a && pip install -e .\n")[1].startswith("installs packages")


#: with UPDATE_README_OUTPUTS=1: the examples that ran, and the digests of what they wrote
_RECORDED: dict = {"ran": set(), "files": {}}


@pytest.fixture(scope="module")
def scratch(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("readme")
    for entry in ROOT.iterdir():
        if entry.name.startswith(".") or entry.name in ("results", "runs", "out", "build", "dist"):
            continue
        (d / entry.name).symlink_to(entry)
    yield d
    if readme_outputs.updating() and _RECORDED["ran"]:  # keep the entries of the examples that did not run
        manifest = readme_outputs.load()
        manifest["files"] = {p: e for p, e in manifest["files"].items() if e["example"] not in _RECORDED["ran"]}
        manifest["files"].update(_RECORDED["files"])
        readme_outputs.save(manifest)


def check_outputs(block: Block, written: list[str], scratch: Path) -> None:
    """The files ``block`` wrote have the digests of the manifest (or are recorded into it)."""
    manifest, example = readme_outputs.load(), EXAMPLES[block]
    where = f"the example at {block.source} line {block.line} ({example!r})"
    problems: list[str] = []  # what no platform explains: unknown, unexpected or vanished files
    differing: list[str] = []  # other bytes: a regression where the manifest was recorded
    for rel in written:
        if readme_outputs.excluded_by(rel, manifest):
            continue
        if not rel.endswith(readme_outputs.COMPARED_SUFFIXES):
            problems.append(f"{rel}: written by {where}, neither a compared output nor excluded in the manifest "
                            "(add a pattern and its reason to its 'excluded')")
            continue
        got = readme_outputs.digest(scratch / rel, scratch, ROOT)
        if readme_outputs.updating():
            before = _RECORDED["files"].get(rel)
            if before is not None and before["example"] != example and before["sha256"] != got:
                problems.append(f"{rel}: written by {where} and, differently, by {before['example']!r}: "
                                "the manifest holds one digest per path")
            _RECORDED["files"][rel] = {"example": example, "sha256": got}
            continue
        entry = manifest["files"].get(rel)
        if entry is None:
            problems.append(f"{rel}: written by {where}, is not in the manifest")
        elif entry["sha256"] != got:
            differing.append(f"{rel}: written by {where}, has SHA-256 {got}, the manifest {entry['sha256']} "
                            f"(recorded for {entry['example']!r})")
    if readme_outputs.updating():
        _RECORDED["ran"].add(example)
    else:
        gone = sorted(p for p, e in manifest["files"].items() if e["example"] == example and p not in written)
        problems += [f"{p}: recorded for {where}, which no longer writes it" for p in gone]
    note = readme_outputs.environment_note(manifest)
    if differing and note and not problems:
        # other floating-point results are expected on another CPU or other numeric packages: the
        # bytes are compared only where the manifest was recorded (the structure is checked anywhere)
        pytest.skip(f"{len(differing)} output(s) of {where} differ from the manifest, but {note}: "
                    f"bytes are compared only there; regenerate here with {readme_outputs.REGENERATE}")
    problems += differing
    assert not problems, ("the example's outputs differ from tests/data/readme_outputs.json:\n  "
                          + "\n  ".join(problems) + (f"\n{note}" if note else "")
                          + "\nif the change is intended, regenerate the manifest "
                          f"and commit it with the change: {readme_outputs.REGENERATE}")


@pytest.mark.readme
@pytest.mark.parametrize("block", BLOCKS, ids=[b.id for b in BLOCKS])
def test_readme_block_runs(block: Block, scratch: Path):
    if block.skip is not None:
        pytest.skip(f"{block.source} line {block.line}: {block.skip}")
    if block.needs_gpu:
        missing = [m for m in GPU_MODULES if importlib.util.find_spec(m) is None]
        if missing:
            pytest.skip(f"{block.source} line {block.line} needs the gpu extra ({', '.join(missing)} missing): "
                        'pip install -e ".[gpu]"')
    code = block.code
    if LANGS[block.lang] == "bash":
        code, why = without_installs(code)
        if why is not None:
            pytest.skip(f"{block.source} line {block.line}: {why}")
    env = dict(os.environ)
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    env.setdefault("MUJOCO_GL", "egl")
    env.pop("DISPLAY", None)
    env.pop("WAYLAND_DISPLAY", None)
    if LANGS[block.lang] == "python":
        stem = "readme" if block.source == "README.md" else re.sub(r"[^A-Za-z0-9]+", "_", block.source[:-3])
        script = scratch / f"{stem}_block_{block.line}.py"
        script.write_text(code)
        cmd = [sys.executable, script.name]
    else:
        cmd = ["bash", "-eo", "pipefail", "-c", code]
    before = readme_outputs.snapshot(scratch)
    r = subprocess.run(cmd, cwd=scratch, env=env, capture_output=True, text=True, timeout=HANG_S,
                       stdin=subprocess.DEVNULL)
    assert r.returncode == 0, (f"{block.source} line {block.line} ({block.lang}) exited {r.returncode}:\n"
                               f"{block.code}\n--- stdout ---\n{r.stdout[-3000:]}\n--- stderr ---\n{r.stderr[-3000:]}")
    written = readme_outputs.changed(before, readme_outputs.snapshot(scratch))
    if LANGS[block.lang] == "python":  # the block's own script is not an output
        written = [p for p in written if p != script.name]
    check_outputs(block, written, scratch)
