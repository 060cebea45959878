"""The README's and the docs pages' examples write the same bytes as before: a manifest of digests.

``tests/test_readme.py`` runs every example block in one scratch folder; after each block, every file
the block wrote or changed there (symlinks into the checkout aside) is checked against
``tests/data/readme_outputs.json``:

* a compared output (``COMPARED_SUFFIXES``: CSV, JSON, TXT, MD, the XML and ASC files the
  examples write, and NumPy ``.npz`` archives) must have the SHA-256 digest recorded for its path,
  after :func:`normalise`;
* a file matching one of the manifest's ``excluded`` patterns is not compared; each pattern gives
  its reason (PNG and SVG figures, Parquet tables and Rerun ``.rrd`` recordings hold bytes that
  depend on the matplotlib, pyarrow and Rerun versions and on the date, not only on this code);
* any other file the examples write, and a recorded file that its example no longer writes, fail.

:func:`normalise` replaces what legitimately differs between two runs of the same code before
hashing, and nothing else (every other byte counts):

* the scratch folder's and the checkout's absolute paths, by ``<scratch>`` and ``<repo>``;
* the values of the JSON keys and CSV columns in ``VOLATILE_KEYS`` and of the Markdown table
  columns in ``VOLATILE_MD_COLUMNS`` (wall-clock durations), by ``<volatile>`` (a JSON or CSV
  file that holds one is re-serialised, by ``json.dumps`` or ``csv.writer``, after the
  replacement; one that holds none is hashed as written);
* a ``.npz`` archive is hashed by its arrays (each name, dtype, shape and bytes, in name order;
  read with ``allow_pickle=False``), not by the zip container's bytes, which depend on the zlib and
  NumPy versions.

When a change of an example's output is intended, regenerate the manifest by running the examples
with ``UPDATE_README_OUTPUTS=1``::

    UPDATE_README_OUTPUTS=1 python -m pytest tests/test_readme.py -m readme -n 0

which rewrites the entries of the examples that ran (keeping the others and the ``excluded``
list) and records the Python, machine and numeric packages' versions (``recorded_with``), and
commit the manifest with the change that explains it. The digests are of floating-point results
(NumPy, BLAS, numba, MuJoCo, software-rendered pictures): another platform or version of those may
change the last digits, and a failure then names the versions that differ.
"""

from __future__ import annotations

import csv
import fnmatch
import hashlib
import io
import json
import os
import re
from pathlib import Path

MANIFEST = Path(__file__).resolve().parent / "data" / "readme_outputs.json"
UPDATE_ENV = "UPDATE_README_OUTPUTS"
REGENERATE = f"{UPDATE_ENV}=1 python -m pytest tests/test_readme.py -m readme -n 0"
COMPARED_SUFFIXES = (".csv", ".json", ".txt", ".md", ".xml", ".asc", ".npz")
#: JSON keys and CSV columns whose values are wall-clock durations, not results
VOLATILE_KEYS = frozenset({"wall_s", "elapsed_s"})
#: Markdown table columns (header cells) that hold wall-clock durations
VOLATILE_MD_COLUMNS = frozenset({"wall s"})


#: the packages whose numerics the outputs depend on (recorded with the digests, named when they differ)
NUMERIC_PACKAGES = ("numpy", "scipy", "numba", "mujoco", "torch", "warp-lang", "mujoco-warp")


#: the CPU features that change floating-point results (fused multiply-add, vector widths: numba's
#: and llvmpipe's JIT code and BLAS kernels are chosen by them)
CPU_FLAGS = ("avx", "avx2", "avx512f", "fma")


def _cpu_flags() -> str:
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return "unknown"
    line = next((x for x in text.splitlines() if x.startswith("flags")), "")
    have = set(line.partition(":")[2].split())
    return " ".join(f for f in CPU_FLAGS if f in have) or "none"


def environment() -> dict[str, str]:
    """Where the digests are computed: the Python, the machine and the numeric packages' versions."""
    import importlib.metadata
    import platform

    env = {"python": platform.python_version(), "machine": platform.machine(), "cpu_flags": _cpu_flags()}
    for name in NUMERIC_PACKAGES:
        try:
            env[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            env[name] = "not installed"
    return env


def environment_note(manifest: dict) -> str:
    """A line naming what differs between the manifest's recording environment and this one."""
    recorded, here = manifest.get("recorded_with", {}), environment()
    diff = [f"{k} {recorded[k]} there, {here.get(k)} here" for k in recorded if recorded[k] != here.get(k)]
    return f"the manifest was recorded with other versions ({'; '.join(diff)})" if diff else ""


def updating() -> bool:
    """The examples' outputs are recorded into the manifest instead of checked against it."""
    return os.environ.get(UPDATE_ENV, "") not in ("", "0")


def load() -> dict:
    """The manifest: ``{"files": {path: {"example": ..., "sha256": ...}}, "excluded": {glob: reason}}``."""
    if not MANIFEST.is_file():
        return {"files": {}, "excluded": {}}
    return json.loads(MANIFEST.read_text())


def save(manifest: dict) -> None:
    MANIFEST.parent.mkdir(parents=True, exist_ok=True)
    manifest = {"about": manifest.get("about", ""), "recorded_with": environment(),
                "excluded": dict(sorted(manifest["excluded"].items())), "files": dict(sorted(manifest["files"].items()))}
    MANIFEST.write_text(json.dumps(manifest, indent=1) + "\n")


def snapshot(folder: Path) -> dict[str, tuple[int, int]]:
    """Every regular file under ``folder`` (not following symlinks): relative path -> (mtime, size)."""
    found = {}
    for dirpath, dirnames, filenames in os.walk(folder):  # followlinks=False: the checkout's links are not entered
        dirnames[:] = [d for d in dirnames if not os.path.islink(os.path.join(dirpath, d)) and d != "__pycache__"]
        for name in filenames:
            path = os.path.join(dirpath, name)
            if os.path.islink(path):
                continue
            st = os.stat(path)
            found[os.path.relpath(path, folder).replace(os.sep, "/")] = (st.st_mtime_ns, st.st_size)
    return found


def changed(before: dict, after: dict) -> list[str]:
    """The files new or changed between two snapshots."""
    return sorted(p for p, v in after.items() if before.get(p) != v)


def excluded_by(path: str, manifest: dict) -> str | None:
    """The ``excluded`` pattern that matches ``path``, if any."""
    return next((g for g in manifest["excluded"] if fnmatch.fnmatchcase(path, g)), None)


def _volatile_json(value):
    if isinstance(value, dict):
        return {k: "<volatile>" if k in VOLATILE_KEYS else _volatile_json(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_volatile_json(v) for v in value]
    return value


def _volatile_md(text: str) -> str:
    """A Markdown text with the cells of its tables' ``VOLATILE_MD_COLUMNS`` replaced."""
    out, cols = [], []
    for line in text.split("\n"):
        if not line.lstrip().startswith("|"):
            cols = []
        else:
            cells = line.split("|")
            if not cols and not set(line.strip()) <= set("|-: "):
                cols = [i for i, c in enumerate(cells) if c.strip() in VOLATILE_MD_COLUMNS] or [-1]
            elif cols != [-1] and not set(line.strip()) <= set("|-: "):
                for i in cols:
                    if i < len(cells) - 1:
                        cells[i] = " <volatile> "
                line = "|".join(cells)
        out.append(line)
    return "\n".join(out)


def _npz(path: Path) -> bytes:
    import numpy as np

    h = hashlib.sha256()
    with np.load(path, allow_pickle=False) as z:
        for name in sorted(z.files):
            a = z[name]
            h.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
            h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest().encode()


def normalise(path: Path, scratch: Path, repo: Path) -> bytes:
    """The bytes of ``path`` with what legitimately varies replaced (see the module's docstring)."""
    if path.suffix == ".npz":
        return _npz(path)
    data = path.read_bytes()
    for folder, tag in ((scratch, b"<scratch>"), (repo, b"<repo>")):
        for form in sorted({str(folder), str(folder.resolve())}, key=len, reverse=True):
            data = data.replace(form.encode(), tag)
    if path.suffix == ".json":
        value = json.loads(data.decode())
        masked = _volatile_json(value)
        return data if masked == value else json.dumps(masked).encode()  # re-serialised only where masked
    if path.suffix == ".md":
        return _volatile_md(data.decode()).encode()
    if path.suffix == ".csv":
        rows = list(csv.reader(io.StringIO(data.decode(), newline="")))
        cols = [i for i, name in enumerate(rows[0]) if name in VOLATILE_KEYS] if rows else []
        if cols:
            for row in rows[1:]:
                for i in cols:
                    if i < len(row):
                        row[i] = "<volatile>"
            out = io.StringIO(newline="")
            csv.writer(out, lineterminator="\n").writerows(rows)
            return out.getvalue().encode()
    return data


def digest(path: Path, scratch: Path, repo: Path) -> str:
    return hashlib.sha256(normalise(path, scratch, repo)).hexdigest()


def example_name(source: str, code: str) -> str:
    """A name for an example that survives edits elsewhere on its page: its file and first command."""
    first = next((ln.strip() for ln in code.splitlines() if ln.strip() and not ln.lstrip().startswith("#")), "")
    first = re.sub(r"\s+#.*$", "", first)  # its comment aside
    return f"{source}: {first}"
