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
perceived_x_deg,           yes       where it was reported (the mean, for a condition mean)
perceived_y_deg
condition                  no        ``references`` (default) or ``dark``
n                          no        trials behind the row (default 1: a single trial)
sd_x_deg, sd_y_deg         no        per-axis SD of the reports of a condition mean (needs n >= 2)
=========================  ========  =============================================================

The trials table that ``python -m experiments run`` writes has these columns, so a simulated run
can be fitted as it is. CSV or Parquet (by the file's suffix). Errors name the file, the column and
the rows.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["REQUIRED", "OPTIONAL", "LocalizationData", "read_data", "DataFormatError"]

REQUIRED = ("saccade_amplitude_deg", "flash_time_ms", "true_x_deg", "true_y_deg", "perceived_x_deg", "perceived_y_deg")
OPTIONAL = ("condition", "n", "sd_x_deg", "sd_y_deg")
CONDITIONS = ("references", "dark")


class DataFormatError(ValueError):
    """A data file that cannot be fitted: unreadable, a missing column, an impossible value."""


@dataclass(frozen=True)
class LocalizationData:
    """Validated columns (numpy arrays, one entry per row) of a localization data set."""

    amplitude_deg: np.ndarray
    flash_time_ms: np.ndarray
    true_deg: np.ndarray  #: (R, 2)
    perceived_deg: np.ndarray  #: (R, 2)
    condition: np.ndarray  #: (R,) str
    n: np.ndarray  #: (R,) int >= 1
    sd_deg: np.ndarray  #: (R, 2), NaN where not given
    source: str = ""

    @property
    def n_observations(self) -> int:
        """Trials behind the data (the sum of n): the n of BIC."""
        return int(self.n.sum())

    def __len__(self) -> int:
        return len(self.amplitude_deg)


def _read_columns(path: Path) -> dict[str, np.ndarray]:
    if not path.exists():
        raise DataFormatError(f"{path}: no such file")
    try:
        if path.suffix.lower() == ".parquet":
            import pyarrow.parquet as pq

            t = pq.read_table(path)
            return {c: np.asarray(t.column(c).to_pylist(), dtype=object) for c in t.column_names}
        import csv

        with path.open(newline="", encoding="utf-8") as fh:
            rows = list(csv.DictReader(fh))
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise DataFormatError(f"{path}: cannot be read as {'Parquet' if path.suffix == '.parquet' else 'CSV'} ({e})") from None
    if not rows:
        raise DataFormatError(f"{path}: no data rows (a header and at least one row are needed)")
    return {c: np.asarray([r[c] for r in rows], dtype=object) for c in rows[0] if c is not None}


def _numbers(path: Path, cols: dict, name: str, blank_ok: bool = False) -> np.ndarray:
    raw = cols[name]
    out = np.empty(len(raw))
    bad = []
    for i, v in enumerate(raw):
        if blank_ok and (v is None or (isinstance(v, str) and not v.strip())):
            out[i] = np.nan  # not given
            continue
        try:
            out[i] = float(v)
        except (TypeError, ValueError):
            bad.append(i)
    if bad:
        raise DataFormatError(f"{path}: column {name} has values that are not numbers in rows "
                              f"{', '.join(str(i + 2) for i in bad[:5])} (e.g. {raw[bad[0]]!r:.30})")
    return out


def _check(path: Path, name: str, ok: np.ndarray, what: str) -> None:
    bad = np.flatnonzero(~ok)
    if len(bad):
        raise DataFormatError(f"{path}: column {name} must be {what}; rows {', '.join(str(i + 2) for i in bad[:5])}"
                              + (f" and {len(bad) - 5} more" if len(bad) > 5 else ""))


def read_data(path) -> LocalizationData:
    """Read and validate a localization data file (CSV or Parquet; see the module docstring).
    Row numbers in errors count the header as row 1."""
    path = Path(path)
    cols = _read_columns(path)
    missing = [c for c in REQUIRED if c not in cols]
    if missing:
        raise DataFormatError(f"{path}: missing column(s) {', '.join(missing)}; required: {', '.join(REQUIRED)} "
                              f"(units in the names: deg, ms)")
    v = {c: _numbers(path, cols, c) for c in REQUIRED}
    _check(path, "saccade_amplitude_deg", np.isfinite(v["saccade_amplitude_deg"]) & (v["saccade_amplitude_deg"] > 0)
           & (v["saccade_amplitude_deg"] <= 40), "saccade amplitudes in degrees, in (0, 40]")
    t = v["flash_time_ms"]
    _check(path, "flash_time_ms", np.isfinite(t) & (t == np.round(t)) & (np.abs(t) <= 1000),
           "whole milliseconds re saccade onset, in [-1000, 1000]")
    for c in ("true_x_deg", "true_y_deg"):
        _check(path, c, np.isfinite(v[c]) & (np.abs(v[c]) <= 60), "degrees within +-60")
    for c in ("perceived_x_deg", "perceived_y_deg"):
        _check(path, c, np.isfinite(v[c]) & (np.abs(v[c]) <= 90), "finite degrees within +-90")
    r = len(t)
    cond = np.asarray(cols["condition"], dtype=str) if "condition" in cols else np.full(r, "references")
    _check(path, "condition", np.isin(cond, CONDITIONS), f"one of {', '.join(CONDITIONS)}")
    n = _numbers(path, cols, "n") if "n" in cols else np.ones(r)
    _check(path, "n", np.isfinite(n) & (n >= 1) & (n == np.round(n)), "whole numbers of trials >= 1")
    sd = np.full((r, 2), np.nan)
    for j, c in enumerate(("sd_x_deg", "sd_y_deg")):
        if c in cols:
            sd[:, j] = _numbers(path, cols, c, blank_ok=True)
            _check(path, c, ~np.isfinite(sd[:, j]) | (sd[:, j] >= 0) & (n >= 2), "SDs >= 0, on rows with n >= 2")
    return LocalizationData(v["saccade_amplitude_deg"], t.astype(int),
                            np.column_stack([v["true_x_deg"], v["true_y_deg"]]),
                            np.column_stack([v["perceived_x_deg"], v["perceived_y_deg"]]), cond, n.astype(int), sd,
                            str(path))
