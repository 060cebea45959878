"""The docs' measured tables, rendered from the repository's CSVs: the batched-env speed tables (docs/batched.md,
from ``benchmarks/batched.py --csv``) and the RL results table (docs/rl.md, from ``experiments/data/rl_results.csv``,
written by ``benchmarks/rl_results.py``). A CSV with a ``heldout_success_iqm`` column is an RL table.

A table in a page is marked by the comment naming its CSV and ends at the comment that closes it::

    <!-- table: benchmarks/data/batched_h100.csv -->
    | ... the rendered table ... |
    <!-- end of table -->

    python benchmarks/tables.py docs/batched.md           # rewrite every marked table from its CSV
    python benchmarks/tables.py docs/batched.md --check   # exit 1 (naming the CSV) where a table is not its CSV's

The CSV paths are relative to the repository root (the folder holding ``pyproject.toml`` above the
page). ``tests/test_benchmark_tables.py`` checks that the pages' tables are their CSVs' rendering.
"""

from __future__ import annotations

import argparse
import csv
import os
import re
import sys
import tempfile
from pathlib import Path

__all__ = ["COLUMNS", "RL_COLUMNS", "render", "marked_tables", "update"]

#: (CSV column, table heading, format) of the rendered columns, in order; ``code`` (what was measured:
#: a branch, a commit) is shown where the CSV has it.
COLUMNS = (
    ("code", "code", "text"),
    ("device", "device", "text"),
    ("eyes", "eyes", "text"),
    ("worlds", "worlds", "int"),
    ("env_steps_per_s", "env-steps/s", "int"),
    ("ms_per_step", "ms/step", "ms"),
    ("host_ms", "host", "ms"),
    ("remap_ms", "remap", "ms"),
    ("physics_ms", "physics", "ms"),
    ("render_ms", "render", "ms"),
    ("retina_ms", "retina", "ms"),
    ("dpft_ms", "DPFT", "ms"),
    ("task_ms", "task", "ms"),
    ("host_sync_ms", "host sync", "ms"),
)
_OPTIONAL = {"code"}
#: The RL results table's CSV columns (``experiments/data/rl_results.csv``), in the order they are written.
RL_COLUMNS = (
    "agent",
    "task",
    "engine",
    "device",
    "actions",
    "env_steps",
    "wall_s",
    "seeds",
    "heldout_success_iqm",
    "ci_low",
    "ci_high",
    "per_seed",
    "mean_return",
    "code",
    "note",
)
_START = re.compile(r"<!-- table: (?P<csv>\S+) -->\n")
_END = "<!-- end of table -->"


def _cell(value: str, kind: str, where: str) -> str:
    if kind == "text":
        return value.replace("|", "/")
    try:
        x = float(value)
    except ValueError:
        raise ValueError(f"{where}: {value!r} is not a number") from None
    if x != x or x in (float("inf"), float("-inf")):
        raise ValueError(f"{where}: {value!r} is not a finite number")
    return f"{x:,.0f}" if kind == "int" else f"{x:.1f}" if kind == "ms" else repr(x)


def _listed(value: str) -> str:
    """A per-seed cell (``"0 1 2"``) as the docs write it (``"0, 1, 2"``); ``-`` where empty."""
    return ", ".join(value.split()) or "-"


def _render_rl(path: Path, rows: list[dict], fields: list[str]) -> str:
    """The RL results table: one line per agent, task, engine, device and action mode."""
    missing = [c for c in RL_COLUMNS if c not in fields]
    if missing:
        raise ValueError(
            f"{path} is not an RL results table (benchmarks/rl_results.py): no column {', '.join(missing)}"
        )
    lines = [
        "| task | agent | engine | device | actions | seeds | env steps per seed | training wall s per seed "
        "| held-out success IQM [95 % CI] | per seed | mean return | measured with |",
        "|" + "---|" * 12,
    ]
    for i, r in enumerate(rows, start=2):
        where = f"{path} line {i}"
        iqm = float(_cell(r["heldout_success_iqm"], "float", f"{where}, heldout_success_iqm"))
        ci = (
            ""
            if not r["ci_low"]
            else (
                f" [{float(_cell(r['ci_low'], 'float', where)):.2f}, {float(_cell(r['ci_high'], 'float', where)):.2f}]"
            )
        )
        ret = float(_cell(r["mean_return"], "float", f"{where}, mean_return"))
        lines.append(
            f"| `{r['task']}` | {_cell(r['agent'], 'text', where)} | {r['engine']} | {r['device']} | "
            f"{r['actions']} | {_listed(r['seeds'])} | {_listed(r['env_steps'])} | {_listed(r['wall_s'])} | "
            f"{iqm:.2f}{ci} | {_listed(r['per_seed'])} | {ret:+.3f} | {_cell(r['code'], 'text', where)} |"
        )
    return "\n".join(lines) + "\n"


def render(path: str | os.PathLike) -> str:
    """The markdown table (heading, rule, one line per CSV row) of a ``benchmarks/batched.py --csv`` file (parts in
    ms per step) or of an RL results CSV. Raises ValueError naming the file where a column is missing or a number
    is not one."""
    path = Path(path)
    try:
        with open(path, newline="") as f:
            reader = csv.DictReader(f)
            rows = list(reader)
            fields = list(reader.fieldnames or [])
    except OSError as e:
        raise ValueError(f"cannot read the benchmark CSV {path}: {e.strerror}") from None
    if "heldout_success_iqm" in fields:
        if not rows:
            raise ValueError(f"{path} has no rows")
        return _render_rl(path, rows, fields)
    missing = [c for c, _, _ in COLUMNS if c not in fields and c not in _OPTIONAL]
    if missing:
        raise ValueError(f"{path} is not a benchmarks/batched.py --csv table: no column {', '.join(missing)}")
    if not rows:
        raise ValueError(f"{path} has no rows")
    cols = [c for c in COLUMNS if c[0] in fields]
    lines = ["| " + " | ".join(h for _, h, _ in cols) + " |", "|" + "---|" * len(cols)]
    for i, row in enumerate(rows, start=2):
        lines.append(
            "| " + " | ".join(_cell(row[c] or "", kind, f"{path} line {i}, {c}") for c, _, kind in cols) + " |"
        )
    return "\n".join(lines) + "\n"


def marked_tables(text: str) -> list[tuple[str, int, int]]:
    """The marked tables of a markdown text: (CSV path, start, end) of each table's text (between the
    marks). Raises ValueError where a mark is not closed."""
    out = []
    for m in _START.finditer(text):
        end = text.find(_END, m.end())
        if end < 0:
            raise ValueError(f"the table of {m.group('csv')} has no closing {_END!r}")
        out.append((m.group("csv"), m.end(), end))
    return out


def _root(page: Path) -> Path:
    """The repository root above ``page``: the nearest folder holding ``pyproject.toml`` (else the page's)."""
    return next((d for d in page.resolve().parents if (d / "pyproject.toml").is_file()), page.parent)


def update(readme: str | os.PathLike, check: bool = False) -> list[str]:
    """Rewrite each marked table of the page ``readme`` from its CSV (paths relative to the repository
    root, ``_root``); with ``check``, write nothing. Returns the CSVs whose tables differed."""
    readme = Path(readme)
    text = readme.read_text()
    root = _root(readme)
    stale, pieces, at = [], [], 0
    for name, start, end in marked_tables(text):
        table = render(root / name)
        if text[start:end] != table:
            stale.append(name)
        pieces += [text[at:start], table]
        at = end
    pieces.append(text[at:])
    if stale and not check:
        fd, tmp = tempfile.mkstemp(dir=readme.parent, prefix=readme.name + ".")
        with os.fdopen(fd, "w") as f:
            f.write("".join(pieces))
        os.replace(tmp, readme)
    return stale


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("readme", help="the markdown page whose marked tables are rendered (docs/batched.md)")
    ap.add_argument("--check", action="store_true", help="write nothing; exit 1 where a table is not its CSV's")
    args = ap.parse_args(argv)
    try:
        stale = update(args.readme, check=args.check)
    except (OSError, ValueError) as e:
        sys.exit(f"error: {e}")
    for name in stale:
        print(f"{'differs from' if args.check else 'rewritten from'} {name}")
    if args.check and stale:
        sys.exit(1)


if __name__ == "__main__":
    main()
