"""The scoreboard's rules: when a phenomenon counts, and a check that a scoreboard keeps them.

One row per (phenomenon, model) with columns ``SCORE_COLUMNS``. The verdicts follow from the other
columns and the calibration table (``calibration``), never typed by hand:

- ``role``: ``predicted`` only if no constant of the model came from the row's ``source``, else
  ``calibrated`` (``calibration.role``);
- ``reproduced``: ``yes`` only if the whole 95 % CI [``ci_low``, ``ci_high``] lies inside
  [``published_low``, ``published_high``]; ``no`` otherwise (a NaN estimate or CI included);
  ``not tested`` where no range is published (empty bounds);
- ``diagnostic``: ``no`` where the no-mechanism ``baseline`` (the true eye, no remapping, no
  references) also reproduces the row -- then the row cannot tell a mechanism from none -- else
  ``yes``.

Every published range's ``source`` names where in the paper it is read (a figure, a table, the
abstract or a page). A row *counts* for a model (``counts``) only if it is predicted, diagnostic and tested.
"""

from __future__ import annotations

import math
import re

from .calibration import read_calibration, role

__all__ = ["SCORE_COLUMNS", "BASELINE", "reproduced", "finalize", "counts", "check_scoreboard"]

SCORE_COLUMNS = [
    "phenomenon",
    "model",
    "source",
    "published_low",
    "published_high",
    "simulated",
    "ci_low",
    "ci_high",
    "role",
    "diagnostic",
    "reproduced",
    "note",
]
_WHERE = re.compile(r"\b(?:Figs?|Table|abstract|text)\b|\bpp?\.\s*\d", re.IGNORECASE)
#: The model with every mechanism off, which decides ``diagnostic``.
BASELINE = "baseline"


def _num(v) -> float:
    if v is None or (isinstance(v, str) and not v.strip()):
        return math.nan
    return float(v)


def reproduced(ci_low, ci_high, published_low, published_high) -> str:
    """``yes`` if [ci_low, ci_high] lies wholly inside [published_low, published_high], ``no`` if
    not (or if the CI is not finite), ``not tested`` if no range is published (empty or NaN)."""
    lo, hi = _num(published_low), _num(published_high)
    if math.isnan(lo) or math.isnan(hi):
        return "not tested"
    c_lo, c_hi = _num(ci_low), _num(ci_high)
    ok = math.isfinite(c_lo) and math.isfinite(c_hi) and lo <= c_lo <= c_hi <= hi
    return "yes" if ok else "no"


def finalize(rows: list[dict], calibration: list[dict] | None = None) -> list[dict]:
    """``rows`` (each with the columns up to ``ci_high`` and a ``note``) with ``role``, ``reproduced``
    and ``diagnostic`` set by the rules above. ValueError if a phenomenon has no baseline row."""
    table = read_calibration() if calibration is None else calibration
    out = [dict(r) for r in rows]
    for r in out:
        r["role"] = role(r["model"], r["source"], table)
        r["reproduced"] = reproduced(r["ci_low"], r["ci_high"], r["published_low"], r["published_high"])
    base = {r["phenomenon"]: r["reproduced"] for r in out if r["model"] == BASELINE}
    for r in out:
        if r["phenomenon"] not in base:
            raise ValueError(f"phenomenon {r['phenomenon']!r} has no {BASELINE} row: diagnostic is undefined")
        r["diagnostic"] = "no" if base[r["phenomenon"]] == "yes" else "yes"
    return [{k: r.get(k, "") for k in SCORE_COLUMNS} for r in out]


def counts(rows: list[dict]) -> dict[str, tuple[int, int]]:
    """model -> (rows reproduced, rows that count): predicted, diagnostic and tested rows only."""
    out: dict[str, list[int]] = {}
    for r in rows:
        c = out.setdefault(r["model"], [0, 0])
        if r["role"] == "predicted" and r["diagnostic"] == "yes" and r["reproduced"] in ("yes", "no"):
            c[1] += 1
            c[0] += r["reproduced"] == "yes"
    return {m: (a, b) for m, (a, b) in out.items()}


def check_scoreboard(rows: list[dict], calibration: list[dict] | None = None) -> list[str]:
    """Every way ``rows`` (e.g. a ``phenomena.csv`` read back) break the rules: missing columns, a
    repeated (phenomenon, model), a phenomenon without a baseline, a CI upside down, or a ``role``,
    ``reproduced`` or ``diagnostic`` that differs from what the rules give. Empty if none."""
    problems = []
    table = read_calibration() if calibration is None else calibration
    seen = set()
    for i, r in enumerate(rows):
        missing = [c for c in SCORE_COLUMNS if c not in r]
        if missing:
            problems.append(f"row {i}: missing columns {', '.join(missing)}")
            continue
        key = (r["phenomenon"], r["model"])
        if key in seen:
            problems.append(f"row {i}: {key} repeated")
        seen.add(key)
        lo, hi = _num(r["ci_low"]), _num(r["ci_high"])
        if math.isfinite(lo) and math.isfinite(hi) and lo > hi:
            problems.append(f"row {i} {key}: ci_low {lo} > ci_high {hi}")
        if not str(r["source"]).strip():
            problems.append(f"row {i} {key}: no source")
        elif not math.isnan(_num(r["published_low"])) and not _WHERE.search(str(r["source"])):
            problems.append(f"row {i} {key}: the range's source names no figure, table or page of its paper")
    if problems:
        return problems
    try:
        expected = finalize(rows, table)
    except ValueError as e:
        return [str(e)]
    for i, (r, want) in enumerate(zip(rows, expected)):
        for col in ("role", "reproduced", "diagnostic"):
            if str(r[col]) != want[col]:
                problems.append(
                    f"row {i} ({r['phenomenon']}, {r['model']}): {col} is {r[col]!r}, the rules give {want[col]!r}"
                )
    return problems
