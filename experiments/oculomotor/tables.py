"""Tables of gaze samples (CSV/TSV exports of any tracker) as arrays.

The text is decoded first (UTF-8, with or without a byte-order mark; UTF-16 with a BOM or without
one, told by its NUL bytes; else latin-1), comment lines (``#``, SMI's ``##`` header) and blank lines
are skipped, the separator is the header's most frequent of tab, comma and semicolon, and fields are
split by Python's ``csv`` module (quoted names and values). Only the time and gaze columns are read:
anything in other columns (text in any encoding, extra fields) is ignored. A decimal comma (a
semicolon- or tab-separated export made in a European locale) is read as a decimal point.

Column names: ``--columns time=NAME,x=NAME,y=NAME[,eye=NAME]`` (``eye``: a column saying which eye a
row belongs to, ``L``/``R`` or ``left``/``right``), a ``--preset`` of :data:`PRESETS`, or, when the
header matches one, the preset it matches (the project's own ``time_ms, x_deg, y_deg`` / ``x_px,
y_px`` first). Per-eye presets name both eyes' columns; the eye is chosen as for an ASC file.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass

import numpy as np

__all__ = ["Columns", "PRESETS", "TableError", "decode", "parse_columns", "read_table", "TIME_UNITS"]

TIME_UNITS = {"ms": 1.0, "us": 1e-3, "s": 1e3}
_MISSING = {"", "nan", "NaN", "NAN", ".", "NA", "N/A", "na", "-", "null", "None"}


class TableError(ValueError):
    """A table that cannot be read; the message names the line or column and the problem."""


@dataclass(frozen=True)
class Columns:
    """Which columns hold time and gaze. ``x``/``y`` may contain ``{eye}``, filled from ``eye_names``
    (``{"left": "L", "right": "R"}``) for per-eye columns. ``time_unit``/``units`` None: from the
    name or the command line. ``row_filter``: (column, value) rows must have (SMI's ``Type = SMP``).
    ``fraction``: gaze as a fraction of the screen (0-1), converted to pixels with the resolution."""

    time: str
    x: str
    y: str
    eye: str | None = None
    time_unit: str | None = None
    units: str | None = None
    eye_names: tuple = ()
    row_filter: tuple | None = None
    fraction: bool = False
    source: str = ""

    def eye_columns(self, eye: str) -> tuple[str, str]:
        names = dict(self.eye_names)
        return self.x.format(eye=names[eye]), self.y.format(eye=names[eye])


#: Documented export layouts. Sources: SMI BeGaze 3.x manual, "Export raw data" (``Time`` in µs,
#: ``Type`` SMP for samples, ``L POR X [px]``), as pymovements' BeGaze parser reads it
#: (``pymovements/gaze/_utils/_parsing_begaze.py``); pymovements' dataset definitions
#: (``pymovements/datasets/gazebase.yaml``: ``n`` ms, ``x, y`` deg; ``judo1000.yaml``: ``time`` ms,
#: ``x_left ... y_right`` px; ``potec.yaml``: ``time`` ms, ``x, y`` px); Gazepoint's Open Gaze API
#: (v2, 2013: ``TIME`` s, ``LPOGX``/``RPOGX``/``BPOGX`` as a fraction of the screen);
#: Tobii Pro Lab's data export (``Recording timestamp`` µs, ``Gaze point X/Y`` px, per eye
#: ``Gaze point left X``).
PRESETS: dict[str, Columns] = {
    "project-deg": Columns("time_ms", "x_deg", "y_deg", time_unit="ms", units="deg", source="this project"),
    "project-px": Columns("time_ms", "x_px", "y_px", time_unit="ms", units="px", source="this project"),
    "smi": Columns(
        "Time",
        "{eye} POR X [px]",
        "{eye} POR Y [px]",
        time_unit="us",
        units="px",
        eye_names=(("left", "L"), ("right", "R")),
        row_filter=("Type", "SMP"),
        source="SMI BeGaze",
    ),
    "tobii": Columns(
        "Recording timestamp",
        "Gaze point {eye}X",
        "Gaze point {eye}Y",
        time_unit="us",
        units="px",
        eye_names=(("left", "left "), ("right", "right ")),
        source="Tobii Pro Lab",
    ),
    "gazepoint": Columns(
        "TIME",
        "{eye}POGX",
        "{eye}POGY",
        time_unit="s",
        units="px",
        fraction=True,
        eye_names=(("left", "L"), ("right", "R")),
        source="Gazepoint",
    ),
    "gazebase": Columns("n", "x", "y", time_unit="ms", units="deg", source="pymovements GazeBase"),
    "judo1000": Columns(
        "time",
        "x_{eye}",
        "y_{eye}",
        time_unit="ms",
        units="px",
        eye_names=(("left", "left"), ("right", "right")),
        source="pymovements JuDo1000",
    ),
    "potec": Columns("time", "x", "y", time_unit="ms", units="px", source="pymovements PoTeC"),
}


def decode(data: bytes, name: str) -> str:
    """The text of a recording's bytes (module docstring); :class:`TableError` for a binary file."""
    if data[:2] in (b"\xff\xfe", b"\xfe\xff"):
        try:
            return data.decode("utf-16")
        except UnicodeDecodeError:
            raise TableError(f"{name}: starts like UTF-16 text but does not decode as UTF-16") from None
    head = data[:4096]
    if b"\x00" in head:
        even, odd = head[0::2].count(0), head[1::2].count(0)
        half = max(len(head) // 2, 1)
        if odd > 0.4 * half and even < 0.05 * half:
            return data.decode("utf-16-le", errors="strict") if len(data) % 2 == 0 else data[:-1].decode("utf-16-le")
        if even > 0.4 * half and odd < 0.05 * half:
            return data.decode("utf-16-be") if len(data) % 2 == 0 else data[:-1].decode("utf-16-be")
        raise TableError(
            f"{name} is a binary file, not a text recording; convert an EyeLink .edf with edf2asc "
            "first, or export samples as CSV"
        )
    if head[:3] == b"\xef\xbb\xbf":
        data = data[3:]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def parse_columns(spec: str) -> Columns:
    """``time=NAME,x=NAME,y=NAME[,eye=NAME]`` as :class:`Columns`; ``TableError`` naming what is wrong."""
    parts = {}
    for item in (p for p in spec.split(",") if p.strip()):
        key, sep, val = item.partition("=")
        key = key.strip()
        if not sep or key not in ("time", "x", "y", "eye") or not val.strip() or key in parts:
            raise TableError(f"--columns takes time=NAME,x=NAME,y=NAME[,eye=NAME] (each once); got {spec!r}")
        parts[key] = val.strip()
    missing = [k for k in ("time", "x", "y") if k not in parts]
    if missing:
        raise TableError(f"--columns needs {', '.join(missing)}=NAME too; got {spec!r}")
    return Columns(parts["time"], parts["x"], parts["y"], eye=parts.get("eye"), source="--columns")


def _unit_from_name(name: str, kind: str) -> str | None:
    n = name.lower().replace("µ", "u").replace("μ", "u")
    pats: tuple[str, ...]
    if kind == "time":
        for unit, pats in (
            ("us", ("[us]", "(us)", "_us", " us")),
            ("ms", ("[ms]", "(ms)", "_ms", " ms")),
            ("s", ("[s]", "(s)", "_s", " s", "_sec", "[sec]")),
        ):
            if any(n.endswith(p) for p in pats):
                return unit
        return None
    for unit, pats in (("deg", ("[deg]", "(deg)", "_deg", " deg", "[°]")), ("px", ("[px]", "(px)", "_px", " px"))):
        if any(n.endswith(p) for p in pats):
            return unit
    return None


@dataclass
class Table:
    """The columns read, per eye (``"left"``/``"right"``, or ``"gaze"`` for one unnamed eye): raw time
    values, x and y; and how they were read."""

    time: dict
    x: dict
    y: dict
    columns: Columns
    time_unit: str | None
    units: str | None
    header: list


def _lines(text: str) -> list[tuple[int, str]]:
    return [(n, ln) for n, ln in enumerate(text.splitlines(), 1) if ln.strip() and not ln.lstrip().startswith("#")]


def _bare(name: str) -> str:
    """A column name without a trailing unit in brackets (``Recording timestamp [μs]``)."""
    return re.sub(r"\s*[\[(][^\])]*[\])]\s*$", "", name)


def _resolve(columns: Columns, header: list[str]) -> Columns:
    """``columns`` with its names as the header spells them: exact, else the same name with a unit in
    brackets after it (whose time unit then overrides the preset's)."""
    bare: dict[str, str] = {}
    for h in header:
        bare.setdefault(_bare(h), h)

    def real(n: str) -> str:
        return n if n in header or n not in bare else bare[n]

    t = real(columns.time)
    unit = _unit_from_name(t, "time") if t != columns.time else None
    xs = columns.x if "{eye}" in columns.x else real(columns.x)
    ys = columns.y if "{eye}" in columns.y else real(columns.y)
    import dataclasses

    return dataclasses.replace(columns, time=t, x=xs, y=ys, time_unit=unit or columns.time_unit)


def _match_preset(header: list[str]) -> Columns | None:
    hs = set(header) | {_bare(h) for h in header}
    for col in PRESETS.values():
        if col.time not in hs:
            continue
        if col.eye_names:
            if any(set(col.eye_columns(e)) <= hs for e, _ in col.eye_names):
                return col
        elif {col.x, col.y} <= hs:
            return col
    return None


def _floats(values: list[str], col: str, lines: list[int], sep: str) -> np.ndarray:
    out = np.empty(len(values))
    comma = sep != ","
    for i, v in enumerate(values):
        v = v.strip()
        if v in _MISSING:
            out[i] = math.nan
            continue
        try:
            out[i] = float(v)
        except ValueError:
            if comma and re.fullmatch(r"[-+]?\d+,\d*", v):
                out[i] = float(v.replace(",", "."))
                continue
            raise TableError(
                f"line {lines[i]}: column {col!r} holds {v[:30]!r}, not a number (missing values: "
                "empty, nan, NA or '.')"
            ) from None
    return out


def read_table(text: str, name: str, columns: Columns | None = None, preset: str | None = None) -> Table:
    """Read the time and gaze columns of a CSV/TSV text (module docstring)."""
    rows = _lines(text)
    if not rows:
        raise TableError(f"{name} has no header line (only comments or blank lines)")
    n0, first = rows[0]
    counts = {s: first.count(s) for s in ("\t", ",", ";")}
    sep = "\t" if counts["\t"] else max(counts, key=counts.__getitem__)
    if not counts[sep]:
        raise TableError(
            f"{name}: its header {first[:80]!r} has no tab, comma or semicolon: not a table of samples "
            "(an EyeLink file needs --format asc)"
        )
    parsed = list(csv.reader([ln for _, ln in rows], delimiter=sep, skipinitialspace=False))
    header = [h.strip().strip('"').strip() for h in parsed[0]]
    body, body_lines = parsed[1:], [n for n, _ in rows[1:]]
    if preset is not None:
        if preset not in PRESETS:
            raise TableError(f"unknown --preset {preset!r}; choose one of {', '.join(PRESETS)}")
        columns = _resolve(PRESETS[preset], header)
    if columns is None:
        columns = _match_preset(header)
        if columns is not None:
            columns = _resolve(columns, header)
        if columns is None:
            raise TableError(
                f"{name}: no known columns in its header {first[:100]!r}: name them with --columns "
                "time=NAME,x=NAME,y=NAME (or a --preset: "
                + ", ".join(PRESETS)
                + "; the project's own names are time_ms and x_deg, y_deg or x_px, y_px)"
            )
    if not body:
        raise TableError(f"{name}: a header and no samples")
    widths = {len(r) for r in body}
    if len(header) > max(widths):
        if header[-1] == "" and len(header) - 1 >= max(widths):
            header = header[:-1]
        else:
            raise TableError(
                f"{name}: the header has {len(header)} fields but no row has more than {max(widths)}: "
                "a header field too many (or a column missing from every row); fix the header"
            )
    last = body[-1]
    if (
        len(last) < len(header)
        and len(widths) > 1
        and text.rstrip("\r\n") == text.rstrip("\r\n").rstrip()
        and not text.endswith(("\n", "\r"))
    ):
        raise TableError(
            f"{name} looks truncated: its last line ({body_lines[-1]}) has {len(last)} of {len(header)} fields"
        )
    index = {h: i for i, h in enumerate(header)}

    def col_index(c: str) -> int:
        if c not in index:
            close = [h for h in header if h.lower() == c.lower()]
            raise TableError(
                f"{name}: no column {c!r} in the header"
                + (
                    f" (did you mean {close[0]!r}?)"
                    if close
                    else f"; it has {', '.join(repr(h) for h in header[:12])}{' ...' if len(header) > 12 else ''}"
                )
            )
        return index[c]

    keep = np.ones(len(body), bool)
    if columns.row_filter and columns.row_filter[0] in index:
        k = index[columns.row_filter[0]]
        keep = np.array([len(r) > k and r[k].strip() == columns.row_filter[1] for r in body])
    body = [r for r, k in zip(body, keep) if k]
    body_lines = [n for n, k in zip(body_lines, keep) if k]

    def column(c: str) -> np.ndarray:
        k = col_index(c)
        short = next((i for i, r in enumerate(body) if len(r) <= k), None)
        if short is not None:
            i = short
            what = "looks truncated: its last line" if i == len(body) - 1 else "has a short line"
            raise TableError(f"{name} {what} ({body_lines[i]}) has {len(body[i])} of {len(header)} fields")
        return _floats([r[k] for r in body], c, body_lines, sep)

    t = column(columns.time)
    xs, ys = {}, {}
    if columns.eye_names:
        for eye, _ in columns.eye_names:
            cx, cy = columns.eye_columns(eye)
            if cx in index and cy in index:
                xs[eye], ys[eye] = column(cx), column(cy)
        if not xs:
            cx, cy = columns.eye_columns(columns.eye_names[0][0])
            col_index(cx)
    elif columns.eye is not None:
        k = col_index(columns.eye)
        lab = np.array([r[k].strip().lower()[:1] if len(r) > k else "" for r in body])
        x, y = column(columns.x), column(columns.y)
        for eye in ("left", "right"):
            m = lab == eye[0]
            if m.any():
                xs[eye], ys[eye] = np.where(m, x, np.nan), np.where(m, y, np.nan)
        if not xs:
            raise TableError(f"{name}: the eye column {columns.eye!r} holds neither L/left nor R/right")
        # a long table: each eye's rows are its samples, on their own time base
        return Table(
            {e: t[lab == e[0]] for e in xs},
            {e: xs[e][lab == e[0]] for e in xs},
            {e: ys[e][lab == e[0]] for e in xs},
            columns,
            columns.time_unit or _unit_from_name(columns.time, "time"),
            columns.units or _unit_from_name(columns.x, "units"),
            header,
        )
    else:
        xs["gaze"], ys["gaze"] = column(columns.x), column(columns.y)
    return Table(
        {e: t for e in xs},
        xs,
        ys,
        columns,
        columns.time_unit or _unit_from_name(columns.time, "time"),
        columns.units or _unit_from_name(columns.x.replace("{eye}", ""), "units"),
        header,
    )
