"""The published data the project fits or scores against (``experiments/data/published/``), and
the check that each file there carries its provenance.

The folder holds two kinds of file:

* **condition-level data** (``NAME.csv``): a published figure or table digitised into ``fit``'s
  format (``modelfit.data``), readable by ``python -m experiments fit`` as it is, each with a
  sidecar ``NAME.json`` holding its provenance (``PROVENANCE_FIELDS``: the paper, the figure or
  table, who digitised it and how, the licence);
* **the sources table** (``sources.csv``, ``SOURCES_COLUMNS``): one row per paper the scoreboard
  (``phenomena.ROWS``) cites, saying what it reports, where (figure, table or abstract), whether
  condition-level data of it are in the folder, and, where they are not, that the scoreboard uses a
  summary range read from the cited place (not trial data).

``check(folder)`` lists every problem (a data file without a sidecar, a sidecar missing a field, a
data file ``fit``'s reader refuses, a malformed sources table); the test suite requires none, and
that every paper ``phenomena.ROWS`` cites has a row in ``sources.csv``.
"""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

__all__ = ["PUBLISHED_DIR", "PROVENANCE_FIELDS", "SOURCES_COLUMNS", "check", "data_files", "cited_papers"]

PUBLISHED_DIR = Path(__file__).resolve().parent.parent / "data" / "published"
#: What a data file's sidecar must say (non-empty strings).
PROVENANCE_FIELDS = ("paper", "figure", "digitised_by", "method", "licence")
SOURCES = "sources.csv"
SOURCES_COLUMNS = ("paper", "cited_at", "reports", "condition_level_data", "digitised_by", "method", "licence")
_YEAR = re.compile(r"^(.*?\b(1[89]|20)\d\d)\b")


def data_files(folder: Path = PUBLISHED_DIR) -> list[Path]:
    """The condition-level data files of ``folder`` (every ``.csv`` but the sources table)."""
    return sorted(p for p in Path(folder).glob("*.csv") if p.name != SOURCES)


def cited_papers(source: str) -> list[str]:
    """The papers ("Author Year") of a scoreboard citation such as "Honda 1989, abstract; Honda 1991"
    (none for "none found")."""
    out = []
    for part in source.split(";"):
        m = _YEAR.match(part.strip())
        if m:
            out.append(m.group(1).strip())
    return out


def _check_sources(path: Path) -> tuple[list[str], list[dict]]:
    if not path.is_file():
        return [f"{path}: missing (the table of the papers the scoreboard cites)"], []
    try:
        with path.open(newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            header = tuple(reader.fieldnames or ())
            rows = list(reader)
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        return [f"{path}: unreadable ({e})"], []
    if header != SOURCES_COLUMNS:
        return [f"{path}: columns {', '.join(header)}; expected {', '.join(SOURCES_COLUMNS)}"], []
    problems = []
    for i, r in enumerate(rows, start=2):
        empty = [c for c in SOURCES_COLUMNS if not (r.get(c) or "").strip()]
        if empty:
            problems.append(f"{path}: row {i} ({r.get('paper')}): empty {', '.join(empty)}")
        if not cited_papers(r.get("paper") or ""):
            problems.append(f"{path}: row {i}: paper {r.get('paper')!r} is not 'Author Year'")
        data = (r.get("condition_level_data") or "").strip()
        if data.endswith(".csv") and not (path.parent / data).is_file():
            problems.append(f"{path}: row {i}: condition_level_data {data} is not in the folder")
    papers = [r.get("paper") or "" for r in rows]
    dup = sorted({p for p in papers if papers.count(p) > 1})
    if dup:
        problems.append(f"{path}: {dup[0]} has more than one row")
    return problems, rows


def check(folder: Path = PUBLISHED_DIR) -> list[str]:
    """Every provenance problem of ``folder`` (empty: none)."""
    import warnings

    from .data import DataFormatError, read_data

    folder = Path(folder)
    problems, _ = _check_sources(folder / SOURCES)
    for path in data_files(folder):
        side = path.with_suffix(".json")
        if not side.is_file():
            problems.append(f"{path}: no provenance sidecar {side.name}")
        else:
            try:
                meta = json.loads(side.read_text(encoding="utf-8"))
            except (OSError, UnicodeDecodeError, ValueError) as e:
                problems.append(f"{side}: unreadable ({e})")
                meta = None
            if meta is not None:
                missing = [
                    f
                    for f in PROVENANCE_FIELDS
                    if not (isinstance(meta, dict) and isinstance(meta.get(f), str) and meta[f].strip())
                ]
                if missing:
                    problems.append(f"{side}: provenance field(s) {', '.join(missing)} missing or empty")
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                read_data(path)
        except DataFormatError as e:
            problems.append(f"{path}: fit's reader refuses it: {e}")
    for side in sorted(folder.glob("*.json")):
        if not side.with_suffix(".csv").is_file():
            problems.append(f"{side}: a sidecar without its data file {side.with_suffix('.csv').name}")
    return problems
