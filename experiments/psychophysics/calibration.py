"""Each theory's calibration set: every constant, its value and the publication it came from.

``experiments/data/calibration.csv`` has one row per constant a scored model reads, with columns
``model, constant, value, source``: ``constant`` is the constant's path on the defaults the
scoreboard runs with (``TrialConfig()``'s fields, e.g. ``observer.prior_sd_deg`` or
``eps_sigma_ms``; ``participant.*`` for the simulated participant's noise, model ``all``: every
model), ``source`` the citation ("Author Year", several separated by ``;``) or ``none: why``.

A phenomenon counts as *predicted* for a model only if none of that model's constants came from the
phenomenon's source (``role``): a number used to set a constant cannot also count as reproduced
(the science notes' rule 8). Citations are compared by first author and year (``citation_keys``).
"""

from __future__ import annotations

import csv
import re
from pathlib import Path
from typing import Any

__all__ = [
    "CALIBRATION_CSV",
    "CALIBRATION_COLUMNS",
    "ALL_MODELS",
    "read_calibration",
    "citation_keys",
    "calibration_keys",
    "role",
    "constant_value",
    "markdown_table",
]

CALIBRATION_CSV = Path(__file__).resolve().parents[1] / "data" / "calibration.csv"
CALIBRATION_COLUMNS = ("model", "constant", "value", "source")
#: The ``model`` of constants every model shares (the simulated participant's).
ALL_MODELS = "all"

_CITATION = re.compile(r"^\s*([A-Z][\w'\-]+)\b.*?\b(1[89]\d\d|20\d\d)[a-z]?\b")


def read_calibration(path: Path | str = CALIBRATION_CSV) -> list[dict]:
    """The calibration table's rows (``value`` as a float); ValueError naming the file and row if a
    column is missing, a value is not a finite number or a source is empty."""
    path = Path(path)
    try:
        with path.open(newline="") as fh:
            reader = csv.DictReader(fh)
            if tuple(reader.fieldnames or ()) != CALIBRATION_COLUMNS:
                raise ValueError(f"{path}: columns must be {', '.join(CALIBRATION_COLUMNS)}; got {reader.fieldnames}")
            rows = list(reader)
    except OSError as e:
        raise ValueError(f"cannot read the calibration table {path}: {e}") from None
    out = []
    for i, r in enumerate(rows, start=2):
        try:
            value = float(r["value"])
        except (TypeError, ValueError):
            raise ValueError(f"{path} line {i}: value {r['value']!r} is not a number") from None
        if value != value or value in (float("inf"), float("-inf")):
            raise ValueError(f"{path} line {i}: value must be finite; got {r['value']!r}")
        if not (r["model"] or "").strip() or not (r["constant"] or "").strip() or not (r["source"] or "").strip():
            raise ValueError(f"{path} line {i}: model, constant and source must not be empty")
        out.append({**r, "value": value})
    return out


def citation_keys(source: str) -> set[tuple[str, str]]:
    """(first author's surname, year) of each citation in ``source`` ("Author, B & C 1997, Fig. 3;
    Honda 1991" -> {("Morrone", "1997"), ("Honda", "1991")}); ``none: ...`` gives the empty set."""
    keys = set()
    for part in str(source).split(";"):
        if part.strip().lower().startswith("none"):
            continue
        m = _CITATION.match(part)
        if m:
            keys.add((m.group(1), m.group(2)))
    return keys


def calibration_keys(model: str, table: list[dict] | None = None) -> set[tuple[str, str]]:
    """Every citation any constant of ``model`` (or of all models) came from."""
    table = read_calibration() if table is None else table
    keys: set = set()
    for r in table:
        if r["model"] in (model, ALL_MODELS):
            keys |= citation_keys(r["source"])
    return keys


def role(model: str, source: str, table: list[dict] | None = None) -> str:
    """``calibrated`` if a constant of ``model`` came from a publication ``source`` cites, else
    ``predicted``."""
    return "calibrated" if citation_keys(source) & calibration_keys(model, table) else "predicted"


def constant_value(path: str, config=None, participant=None) -> float:
    """The value the code uses for a calibration row's ``constant``: ``participant.<field>`` on the
    scoreboard's participant, anything else a (dotted) attribute of ``TrialConfig()`` (or
    ``config``). AttributeError names a path that does not exist."""
    from .participant import PARTICIPANT
    from .trial import TrialConfig

    head, _, rest = path.partition(".")
    obj: Any  # the participant or configuration, then each attribute along the path
    if head == "participant":
        obj, parts = PARTICIPANT if participant is None else participant, rest.split(".")
    else:
        obj, parts = TrialConfig() if config is None else config, path.split(".")
    for p in parts:
        if not hasattr(obj, p):
            raise AttributeError(f"calibration constant {path!r}: {type(obj).__name__} has no {p!r}")
        obj = getattr(obj, p)
    return float(obj)


def markdown_table(table: list[dict] | None = None) -> str:
    """The calibration table as Markdown (docs/psychophysics/theories.md): one line per model and source, its
    constants and values."""
    table = read_calibration() if table is None else table
    groups: dict = {}
    for r in table:
        groups.setdefault((r["model"], r["source"]), []).append(f"`{r['constant']}` = {r['value']:g}")
    lines = ["| model | constants | source |", "|---|---|---|"]
    lines += [f"| {m} | {', '.join(c)} | {src} |" for (m, src), c in groups.items()]
    return "\n".join(lines) + "\n"
