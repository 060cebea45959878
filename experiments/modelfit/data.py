"""The data format that ``python -m experiments fit`` and ``compare`` read: a localization table.

One row per trial, or per condition mean with its n (and optionally its per-axis SDs). Positions
are head-centred degrees (azimuth > 0 right, elevation > 0 up) in the convention of the flash
paradigm: a horizontal saccade from -A/2 to +A/2 deg azimuth, so the target is at (+A/2, 0) (mirror
leftward saccades, shift other layouts). Columns:

=========================  ========  =============================================================
column                     required  meaning
=========================  ========  =============================================================
saccade_amplitude_deg      yes       A, in (0, 40]
flash_time_ms              yes       flash onset re saccade onset, whole ms in [-1000, 1000]
true_x_deg, true_y_deg     yes       where the flash was, within +-60 deg
perceived_x_deg,           yes       where it was reported (the mean, for a condition mean), within
perceived_y_deg                      +-90 deg; ``perceived_y_deg`` may be empty where a study measured
                                     only the error along the saccade (1-D localization: the row's
                                     likelihood uses x alone)
condition                  no        ``references`` (default) or ``dark`` (case, spaces ignored)
n                          no        trials behind the row: a whole number in [1, 10**9] (default 1:
                                     a single trial)
sd_x_deg, sd_y_deg         no        per-axis SD of the reports of a condition mean, in [0, 90]
                                     (needs n >= 2); an empty cell (Parquet: null) = not given
=========================  ========  =============================================================

``run``'s trials table has these columns (a simulated run is fitted as it is; other columns are
ignored). CSV or Parquet (suffix ``.parquet`` or ``.pq``).

The checks (a :class:`DataFormatError` names the file, rows and column), the conventions reported
with a :class:`DataConventionWarning`, and what is not checked: ``docs/psychophysics/fitting.md``.
"""

from __future__ import annotations

import csv
import io
import re
import warnings
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path

import numpy as np

__all__ = ["REQUIRED", "OPTIONAL", "LocalizationData", "read_data", "DataFormatError", "DataConventionWarning", "MAX_N"]

REQUIRED = ("saccade_amplitude_deg", "flash_time_ms", "true_x_deg", "true_y_deg", "perceived_x_deg", "perceived_y_deg")
OPTIONAL = ("condition", "n", "sd_x_deg", "sd_y_deg")
CONDITIONS = ("references", "dark")
#: The largest n a row may have (trials behind one row).
MAX_N = 10**9
_MAX_SD = 90.0  # perceived positions lie within +-90 deg: no SD of them can be larger
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|[+-]?(?:inf|infinity|nan)", re.IGNORECASE)
_CSV_FIX = 'save the sheet as "CSV UTF-8 (comma delimited)" (Excel) or a .parquet file'


class DataFormatError(ValueError):
    """A data file that cannot be fitted: unreadable, a missing column, an impossible value."""


class DataConventionWarning(UserWarning):
    """Values that look like another convention (radians, seconds, unmirrored leftward saccades, a
    mirrored axis); the file is read as the format says, and the warning says what was assumed."""


@dataclass(frozen=True)
class LocalizationData:
    """Validated columns (numpy arrays, one entry per row) of a localization data set."""

    amplitude_deg: np.ndarray
    flash_time_ms: np.ndarray
    true_deg: np.ndarray  #: (R, 2)
    perceived_deg: np.ndarray  #: (R, 2); y NaN on 1-D rows (only the error along the saccade measured)
    condition: np.ndarray  #: (R,) str
    n: np.ndarray  #: (R,) int >= 1
    sd_deg: np.ndarray  #: (R, 2), NaN where not given
    source: str = ""

    @property
    def measured(self) -> np.ndarray:
        """(R, 2) bool: the axes each row reports (1-D rows: x only)."""
        return np.isfinite(self.perceived_deg)

    @property
    def n_observations(self) -> int:
        """Trials behind the data (the sum of n): the n of BIC."""
        return int(self.n.sum())

    def __len__(self) -> int:
        return len(self.amplitude_deg)


# ---------------------------------------------------------------------------------------------- reading
def _rows(nums) -> str:
    """'row 3' or 'rows 3, 5, 7, 9, 11 and 4 more'."""
    nums = [int(x) for x in nums]
    if len(nums) == 1:
        return f"row {nums[0]}"
    head = ", ".join(str(x) for x in nums[:5])
    return f"rows {head}" + (f" and {len(nums) - 5} more" if len(nums) > 5 else "")


@dataclass
class _Table:
    columns: dict  # name -> list of raw cell values (str, None, or Parquet's Python values)
    rownum: np.ndarray  # the file row of each data row (header = row 1)
    kind: str  # "CSV" or "Parquet"


def _read_bytes(path: Path) -> bytes:
    if not path.exists():
        raise DataFormatError(f"{path}: no such file")
    if path.is_dir():
        raise DataFormatError(
            f"{path}: is a directory, not a data file; give the CSV or Parquet file in it (e.g. {path / 'trials.csv'})"
        )
    if not path.is_file():
        raise DataFormatError(f"{path}: not a regular file (a device or pipe?); give a CSV or Parquet file")
    try:
        data = path.read_bytes()
    except PermissionError:
        raise DataFormatError(
            f"{path}: cannot be read: permission denied; make it readable (chmod u+r) or copy it somewhere readable"
        ) from None
    except OSError as e:
        raise DataFormatError(f"{path}: cannot be read ({e})") from None
    if not data:
        raise DataFormatError(f"{path}: empty file (0 bytes); it needs a header line and at least one data row")
    return data


def _unique_names(path: Path, names: list[str]) -> None:
    seen: dict[str, int] = {}
    for j, c in enumerate(names):
        if c in REQUIRED + OPTIONAL:
            if c in seen:
                raise DataFormatError(
                    f"{path}: column {c} appears twice in the header (columns {seen[c] + 1} and "
                    f"{j + 1}); delete or rename one"
                )
            seen[c] = j


def _read_parquet(path: Path, data: bytes) -> _Table:
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        t = pq.read_table(io.BytesIO(data))
    except (pa.ArrowException, OSError, ValueError, EOFError) as e:
        raise DataFormatError(
            f"{path}: cannot be read as Parquet ({e}); write it with pandas' to_parquet, "
            f"pyarrow or polars, or give a .csv file"
        ) from None
    if t.num_columns == 0:
        raise DataFormatError(f"{path}: a Parquet file with no columns; required columns: {', '.join(REQUIRED)}")
    names = [str(c).strip() for c in t.column_names]
    _unique_names(path, names)
    if t.num_rows == 0:
        raise DataFormatError(f"{path}: no data rows (the Parquet file has columns but zero rows)")
    cols: dict = {}
    for j, c in enumerate(names):
        if c and c not in cols:  # the first of an unused name given twice; nameless columns dropped
            cols[c] = t.column(j).to_pylist()
    return _Table(cols, np.arange(t.num_rows) + 2, "Parquet")


def _field_over_limit(lines: list[str], start: int, limit: int) -> int | None:
    """Index of the field of the record starting at ``lines[start]`` that exceeds ``limit``."""
    field = length = 0
    quoted = False
    for line in lines[start:]:
        for ch in line:
            if ch == '"':
                quoted = not quoted
            elif ch == "," and not quoted:
                field, length = field + 1, 0
                continue
            elif ch in "\r\n" and not quoted:
                return None
            length += 1
            if length > limit:
                return field
    return None


def _read_csv(path: Path, data: bytes) -> _Table:
    if data[:4] == b"PAR1":
        raise DataFormatError(
            f"{path}: a Parquet file with a {path.suffix or 'missing'} suffix; rename it to {path.stem}.parquet"
        )
    if (
        data[:4] == b"PK\x03\x04"
        or data[:8] == b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1"
        or path.suffix.lower() in (".xlsx", ".xls")
    ):
        raise DataFormatError(f"{path}: an Excel workbook, not CSV; {_CSV_FIX}")
    if data[:2] in (b"\xff\xfe", b"\xfe\xff"):
        raise DataFormatError(f'{path}: UTF-16 text (Excel\'s "Unicode Text"?), not UTF-8 CSV; {_CSV_FIX}')
    if b"\x00" in data:
        line = data[: data.index(b"\x00")].count(b"\n") + 1
        raise DataFormatError(f"{path}: binary data (a NUL byte at line {line}), not a CSV text file; {_CSV_FIX}")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        line = data[: e.start].count(b"\n") + 1
        line_start = data.rfind(b"\n", 0, e.start) + 1
        field = data[line_start : e.start].count(b",")
        header = next(csv.reader([data.split(b"\n", 1)[0].decode("utf-8-sig", "replace")]), [])
        col = f", column {header[field].strip()}" if line > 1 and field < len(header) else ""
        raise DataFormatError(
            f"{path}: not UTF-8 text (byte 0x{data[e.start]:02x} at line {line}{col}: a Latin-1 / "
            f"Windows-1252 export?); {_CSV_FIX}"
        ) from None
    lines = list(io.StringIO(text, newline=""))
    reader = csv.reader(iter(lines))
    records: list[list[str]] = []
    while True:
        start = reader.line_num
        try:
            rec = next(reader)
        except StopIteration:
            break
        except csv.Error as e:
            row = len(records) + 1
            limit = csv.field_size_limit()
            if "field larger than field limit" in str(e):
                j = _field_over_limit(lines, start, limit)
                names = [c.strip() for c in records[0]] if records else []
                col = (
                    f", column {names[j]}"
                    if j is not None and j < len(names)
                    else (f", field {j + 1}" if j is not None else "")
                )
                raise DataFormatError(
                    f"{path}: row {row}{col}: a field longer than {limit} characters; usually an "
                    f'unclosed double quote (") there that swallows the rest of the file: close '
                    f"or remove it"
                ) from None
            raise DataFormatError(f"{path}: row {row}: not valid CSV ({e})") from None
        records.append(rec)
    if not records or not any(f.strip() for f in records[0]):
        raise DataFormatError(f"{path}: no header: the first line must name the columns ({', '.join(REQUIRED)})")
    header = [c.strip() for c in records[0]]
    if len(header) == 1 and (";" in header[0] or "\t" in header[0]):
        sep = "';'" if ";" in header[0] else "tabs"
        raise DataFormatError(
            f"{path}: row 1: the header's fields are separated by {sep}, not commas (a "
            f"European-locale export?); {_CSV_FIX}, with '.' as the decimal point"
        )
    if all(_NUMBER.fullmatch(c) for c in header if c) and any(header):
        raise DataFormatError(
            f"{path}: row 1 holds numbers, not column names: the first line must be the header "
            f"({', '.join(REQUIRED)}, ...)"
        )
    _unique_names(path, header)
    keep = {}  # name -> field index (the first of an unused name given twice; nameless columns dropped)
    for j, c in enumerate(header):
        if c and c not in keep:
            keep[c] = j
    named_len = max(keep.values()) + 1  # rows may leave out trailing nameless columns
    body, rownum, extra, short, repeats = [], [], [], [], []
    for i, rec in enumerate(records[1:], start=2):
        if not any(f.strip() for f in rec):
            continue  # a blank line, or a row of empty fields (spreadsheet exports leave them)
        if len(rec) > len(header) and any(f.strip() for f in rec[len(header) :]):
            extra.append(i)
        elif len(rec) < named_len:
            short.append(i)
        elif [f.strip() for f in rec[: len(header)]] == header:
            repeats.append(i)
        body.append(rec)
        rownum.append(i)
    if extra:
        raise DataFormatError(
            f"{path}: {_rows(extra)}: more fields than the header's {len(header)} columns, after "
            f"column {header[-1] or len(header)} (a ',' inside a value, e.g. a decimal comma? quote "
            f"the value or use '.' as the decimal point; or name the extra column in the header)"
        )
    if short:
        first = records[short[0] - 1]
        raise DataFormatError(
            f"{path}: {_rows(short)}: fewer fields than the header's {len(header)} columns (row "
            f"{short[0]} has {len(first)}: column {header[len(first)] or len(first) + 1} onwards "
            f"missing); add the missing fields (empty ones are ',,')"
        )
    if repeats:
        raise DataFormatError(
            f"{path}: {_rows(repeats)}: a repeat of the header line (files concatenated?), in "
            f"column {header[0]} and every other; delete those rows"
        )
    if not body:
        raise DataFormatError(
            f"{path}: no data rows: only the header (row 1); a header and at least one row are needed"
        )
    cols = {c: [rec[j] for rec in body] for c, j in keep.items()}
    return _Table(cols, np.asarray(rownum), "CSV")


def _read_table(path: Path) -> _Table:
    data = _read_bytes(path)
    if path.suffix.lower() in (".parquet", ".pq"):
        return _read_parquet(path, data)
    return _read_csv(path, data)


# ---------------------------------------------------------------------------------------------- values
def _as_float(v):
    """A cell as a float; None for an empty cell; ValueError / TypeError for anything else."""
    if v is None:
        return None
    if isinstance(v, str):
        s = v.strip()
        if not s:
            return None
        if not _NUMBER.fullmatch(s):
            raise ValueError(s)
        return float(s)
    if isinstance(v, (bool, np.bool_)):
        raise TypeError("a boolean")
    if isinstance(v, (int, float, np.integer, np.floating, Decimal)):
        try:
            return float(v)
        except OverflowError:
            return float("inf") if v > 0 else float("-inf")
    raise TypeError(type(v).__name__)


def _numbers(path: Path, tab: _Table, name: str, blank_ok: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The column as floats (NaN where empty) and the mask of empty cells."""
    raw = tab.columns[name]
    out = np.empty(len(raw))
    empty = np.zeros(len(raw), bool)
    bad, blank = [], []
    for i, v in enumerate(raw):
        try:
            f = _as_float(v)
        except (TypeError, ValueError):
            bad.append(i)
            continue
        if f is None:
            empty[i] = True
            out[i] = np.nan
            if not blank_ok:
                blank.append(i)
        else:
            out[i] = f
    if bad:
        v = raw[bad[0]]
        if isinstance(v, str) and v.strip().upper() in ("NA", "N/A", "NULL", "NONE", "-", "?"):
            hint = (
                'leave the cell empty where no value is given (R: write.csv(..., na = ""))'
                if blank_ok
                else "a missing value: every row needs one (delete rows without it)"
            )
        elif isinstance(v, str) and re.fullmatch(r"\s*[+-]?\d+,\d+\s*", v):
            hint = "a decimal comma? use '.'"
        elif isinstance(v, str):
            hint = "plain numbers with '.' as the decimal point and no units, e.g. 12.5"
        else:
            hint = f"numbers, not {type(v).__name__} values (convert the {tab.kind} column)"
        raise DataFormatError(
            f"{path}: column {name} has values that are not numbers in {_rows(tab.rownum[bad])} "
            f"(row {tab.rownum[bad[0]]}: {v!r:.40}); {hint}"
        )
    if blank:
        raise DataFormatError(
            f"{path}: column {name} is empty in {_rows(tab.rownum[blank])}; every row needs a "
            f"{name} (delete rows without one)"
        )
    return out, empty


def _check(path: Path, tab: _Table, name: str, ok: np.ndarray, what: str, fix: str = "") -> None:
    bad = np.flatnonzero(~ok)
    if len(bad):
        v = tab.columns[name][bad[0]] if name in tab.columns else None
        example = "" if v is None else f" ({v!r:.40})" if len(bad) == 1 else f" (row {tab.rownum[bad[0]]}: {v!r:.40})"
        raise DataFormatError(
            f"{path}: column {name} must be {what}; {_rows(tab.rownum[bad])}{example}" + (f"; {fix}" if fix else "")
        )


def _duplicates(path: Path, tab: _Table, parsed: dict) -> None:
    """Rows identical in every column: the parsed value where the column is the format's, the
    stripped text elsewhere."""

    def cell(c, i):
        if c in parsed:
            return parsed[c][i]
        x = tab.columns[c][i]
        return "" if x is None else str(x).strip()

    first: dict = {}
    pairs = []
    for i in range(len(tab.rownum)):
        k = tuple(cell(c, i) for c in tab.columns)
        if k in first:
            pairs.append((tab.rownum[first[k]], tab.rownum[i]))
        else:
            first[k] = i
    if pairs:
        names = ", ".join(list(tab.columns)[:8]) + (f" and {len(tab.columns) - 8} more" if len(tab.columns) > 8 else "")
        more = (
            (
                "; also rows "
                + ", ".join(f"{x} and {y}" for x, y in pairs[1:4])
                + (f" (and {len(pairs) - 4} more pairs)" if len(pairs) > 4 else "")
            )
            if len(pairs) > 1
            else ""
        )
        raise DataFormatError(
            f"{path}: rows {pairs[0][0]} and {pairs[0][1]} are identical in every column ({names}){more}; a duplicated "
            f"trial row is almost always a copy-paste mistake: delete it. If these are distinct trials with identical "
            f"values, aggregate them into one row with n (and sd_x_deg = sd_y_deg = 0, which keeps them equivalent to "
            f"separate trials)"
        )


def _conventions(path: Path, amp, t, true, perceived) -> list[str]:
    out = []
    if np.all(amp < 1):
        out.append(
            f"all saccade_amplitude_deg < 1 (largest {amp.max():g}): these look like radians; they are read "
            f"as degrees (multiply radians by 57.2958)"
        )
    if np.all(np.abs(t) <= 1):
        out.append(
            "all flash_time_ms within [-1, 1]: these look like seconds; they are read as milliseconds "
            "(multiply seconds by 1000)"
        )
    if np.all(true[:, 0] < 0):
        out.append(
            "every true_x_deg < 0: every flash lies left of straight ahead, on the side the saccade starts "
            "from (the format's saccade goes from -A/2 to +A/2 azimuth, the target at +A/2); if the saccades "
            "were leftward, mirror azimuths (negate true_x_deg and perceived_x_deg); read as given"
        )
    for j, ax in enumerate("xy"):
        ok = np.isfinite(perceived[:, j])  # 1-D rows have no perceived y
        a, b = true[ok, j], perceived[ok, j]
        if len(a) >= 10 and len(np.unique(a)) >= 2 and np.std(b) > 0:
            rho = float(np.corrcoef(a, b)[0, 1])
            if rho < -0.5:
                out.append(
                    f"perceived_{ax}_deg falls as true_{ax}_deg rises (correlation {rho:.2f}): one of them "
                    f"looks mirrored (e.g. screen coordinates, y down, or an unmirrored leftward saccade); "
                    f"read as given (azimuth > 0 right, elevation > 0 up)"
                )
    return [f"{path}: {m}" for m in out]


def read_data(path) -> LocalizationData:
    """Read and validate a localization data file (CSV or Parquet; see the module docstring for the
    columns, the checks and the convention warnings). Raises :class:`DataFormatError` naming the
    file, the rows (the header is row 1) and the column; warns :class:`DataConventionWarning`."""
    path = Path(path)
    tab = _read_table(path)
    cols = tab.columns
    missing = [c for c in REQUIRED if c not in cols]
    if missing:
        lower = {c.lower().replace(" ", "_"): c for c in cols}
        near = [f"{lower[m]!r} for {m}" for m in missing if m in lower]
        raise DataFormatError(
            f"{path}: row 1 (the header): missing column(s) {', '.join(missing)}; required: "
            f"{', '.join(REQUIRED)} (units in the names: deg, ms)"
            + (f"; names are case-sensitive: rename {', '.join(near)}" if near else "")
        )
    v = {c: _numbers(path, tab, c)[0] for c in REQUIRED if c != "perceived_y_deg"}
    v["perceived_y_deg"], no_y = _numbers(path, tab, "perceived_y_deg", blank_ok=True)  # empty: 1-D, x alone
    a = v["saccade_amplitude_deg"]
    _check(
        path,
        tab,
        "saccade_amplitude_deg",
        np.isfinite(a) & (a > 0) & (a <= 40),
        "saccade amplitudes in degrees, in (0, 40]",
    )
    t = v["flash_time_ms"]
    seconds = bool(np.all(np.isfinite(t) & (np.abs(t) <= 1)))
    _check(
        path,
        tab,
        "flash_time_ms",
        np.isfinite(t) & (t == np.round(t)) & (np.abs(t) <= 1000),
        "whole milliseconds re saccade onset, in [-1000, 1000]",
        "these look like seconds (all within [-1, 1]): multiply by 1000" if seconds else "",
    )
    for c in ("true_x_deg", "true_y_deg"):
        _check(path, tab, c, np.isfinite(v[c]) & (np.abs(v[c]) <= 60), "degrees within +-60")
    for c in ("perceived_x_deg", "perceived_y_deg"):
        empty_ok = no_y if c == "perceived_y_deg" else np.zeros(len(no_y), bool)
        _check(
            path,
            tab,
            c,
            empty_ok | np.isfinite(v[c]) & (np.abs(v[c]) <= 90),
            "finite degrees within +-90",
            "a trial without a report (NaN) cannot be fitted: delete its row"
            + (
                "; leave perceived_y_deg empty where only the error along the saccade was measured"
                if c == "perceived_y_deg"
                else ""
            ),
        )
    r = len(t)
    parsed: dict[str, np.ndarray | list] = dict(v)
    if "condition" in cols:
        cond = np.asarray(["" if x is None else str(x).strip().lower() for x in cols["condition"]], dtype=object)
        _check(
            path,
            tab,
            "condition",
            np.isin(cond, CONDITIONS),
            f"one of {', '.join(CONDITIONS)}",
            "or drop the column (every row: references)",
        )
        cond = cond.astype(str)
        parsed["condition"] = list(cond)
    else:
        cond = np.full(r, "references")
    if "n" in cols:
        n = _numbers(path, tab, "n")[0]
        _check(
            path,
            tab,
            "n",
            np.isfinite(n) & (n >= 1) & (n <= MAX_N) & (n == np.round(n)),
            "whole numbers of trials in [1, 10**9]",
            "n counts the trials behind the row (at most 10**9, so that sums of n cannot overflow)",
        )
        parsed["n"] = n
    else:
        n = np.ones(r)
    sd = np.full((r, 2), np.nan)
    for j, c in enumerate(("sd_x_deg", "sd_y_deg")):
        if c in cols:
            s, empty = _numbers(path, tab, c, blank_ok=True)
            _check(
                path,
                tab,
                c,
                empty | np.isfinite(s) & (s >= 0) & (s <= _MAX_SD),
                f"finite SDs in [0, {_MAX_SD:g}] degrees",
                'leave the cell empty where no SD is given (not inf or nan; R: write.csv(..., na = ""))',
            )
            _check(
                path,
                tab,
                c,
                empty | (n >= 2),
                "given only on rows with n >= 2 (an SD of one trial is undefined)",
                "leave it empty or give the row's n",
            )
            if c == "sd_y_deg":
                _check(
                    path,
                    tab,
                    c,
                    empty | ~no_y,
                    "empty where perceived_y_deg is (no report across, no SD of it)",
                    "leave it empty on 1-D rows",
                )
            sd[:, j] = s
            parsed[c] = [None if e else x for e, x in zip(empty, s)]
    _duplicates(path, tab, {k: list(x) for k, x in parsed.items()})
    true = np.column_stack([v["true_x_deg"], v["true_y_deg"]])
    perceived = np.column_stack([v["perceived_x_deg"], v["perceived_y_deg"]])
    for m in _conventions(path, a, t, true, perceived):
        warnings.warn(m, DataConventionWarning, stacklevel=2)
    return LocalizationData(a, t.astype(np.int64), true, perceived, cond, n.astype(np.int64), sd, str(path))
