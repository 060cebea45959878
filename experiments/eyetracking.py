"""Eye-tracker recordings in: samples, blinks and saccades out, and a person's main sequence.

``python -m experiments saccades --recording FILE --out DIR`` reads a recording with
:func:`read_recording`, finds its saccades with :func:`detect_saccades`, measures them with
:func:`main_sequence_rows` (``main_sequence.csv``) and fits the burst generator to them
(``experiments.generator_fit``: ``generator.json``, ``main_sequence.png``).

Formats
-------
* **EyeLink ASC** (``edf2asc`` output; ``.asc``): parsed by ``pymovements.gaze.from_asc``, which
  takes the screen resolution from ``GAZE_COORDS`` and the sampling rate from ``SAMPLES ... RATE``.
  ASC files carry no physical screen size or viewing distance: give them with
  ``--screen WIDTH_CM HEIGHT_CM DISTANCE_CM`` (or all five numbers, see below). The first eye of a
  binocular file is used. Blinks are the file's ``SBLINK/EBLINK`` events and its missing (``.``)
  samples; saccades are the file's own ``SSACC/ESACC`` events when it has them (``--detect file``,
  the default ``auto``), else detected (``--detect engbert``).
* **CSV/TSV of samples** (``.csv``, ``.tsv``, ``.txt``; comma or tab separated, one header line):
  a column ``time_ms`` (sample time in ms, increasing, uniformly sampled) and either
  ``x_deg, y_deg`` (gaze in degrees of visual angle, y up; no geometry needed) or ``x_px, y_px``
  (screen pixels, origin upper left, y down; needs ``--screen WIDTH_PX HEIGHT_PX WIDTH_CM
  HEIGHT_CM DISTANCE_CM``). Blinks / track loss are empty or ``nan`` cells. Other columns are
  ignored. The sampling rate is the median sample interval's inverse.

Screen geometry: ``Screen(width_px, height_px, width_cm, height_cm, distance_cm)``; pixels are
converted to degrees by ``pymovements`` (``Gaze.pix2deg``: per axis, ``atan`` of the centred
pixel distance over the viewing distance in pixels).

What pymovements does and what is written here
----------------------------------------------
* pymovements: ASC and CSV parsing (``from_asc`` with events, ``from_csv``), the pixel-to-degree
  conversion, the detection velocity (``pos2vel``, five-point differentiator) and the Engbert &
  Kliegl (2003) saccade detection (``detect('microsaccades')``: the noise-adaptive elliptic
  velocity threshold, 6 median-based SDs; it serves for saccades of any size).
* numpy, here: the checks that make bad files usage errors (pymovements warns and goes on, or
  raises polars errors that do not name the problem); blink masking and the rule that drops
  saccades near blinks; and the kinematic measures of each saccade, because the fit
  (``experiments.generator_fit``) must apply *the same* measurement to the model's noise-free
  traces sampled at the recording's rate (a forward model of the measurement, so the filtering
  of a 250 Hz recording biases data and model alike) -- that needs a numpy function it can call
  on simulated arrays, not a ``Gaze``.

Measures (:func:`measure_saccade`), as the rest of the project measures saccades: eye speed from
the five-point differentiator (``(x[n+2] + x[n+1] - x[n-1] - x[n-2]) / (6 dt)``); duration
between the 30 deg/s crossings around the peak (linearly interpolated between samples); peak
velocity the largest speed between them; amplitude the distance between the median gaze
4-20 ms before the onset crossing and 20-40 ms after the offset crossing (the eye at rest;
clipped to the neighbouring saccades); direction ``atan2(dy, dx)`` in degrees, 0 rightward,
90 upward; skewness the time of peak velocity as a fraction of the duration, reported only at
sampling rates of 250 Hz or more (``SKEWNESS_MIN_RATE_HZ``: below it the peak's time is
uncertain by more than ~15 % of a 25 ms saccade), else NaN.

Saccades are dropped when a blink or a missing sample lies within 20 ms of them
(``BLINK_MARGIN_MS``), when a crossing cannot be found inside the recording, or when the eye does
not rest before or after them (fewer than 2 samples in a window).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["Screen", "Recording", "RecordingError", "read_recording", "detect_saccades", "measure_saccade",
           "main_sequence_rows", "write_recording", "speed_deg_s", "synthetic_session", "FORMATS",
           "SKEWNESS_MIN_RATE_HZ", "BLINK_MARGIN_MS", "ROW_FIELDS"]

FORMATS = ("asc", "csv")
THRESHOLD_DEG_S = 30.0  # = models.saccade_generator.DETECTION_THRESHOLD_DEG_S (not imported: no MuJoCo here)
SKEWNESS_MIN_RATE_HZ = 250.0
BLINK_MARGIN_MS = 20.0
PRE_WINDOW_MS = (20.0, 4.0)  # median gaze this long before the onset crossing (from, to)
POST_WINDOW_MS = (20.0, 40.0)  # ... and after the offset crossing
ROW_FIELDS = ("saccade", "onset_ms", "amplitude_deg", "duration_ms", "peak_velocity_deg_s", "direction_deg",
              "skewness")
_SUFFIX_FORMAT = {".asc": "asc", ".csv": "csv", ".tsv": "csv", ".txt": "csv"}


class RecordingError(ValueError):
    """A recording that cannot be used, with a message naming the file and the problem."""


@dataclass(frozen=True)
class Screen:
    """Screen geometry: resolution (px), visible size (cm) and viewing distance (cm)."""

    width_px: int
    height_px: int
    width_cm: float
    height_cm: float
    distance_cm: float

    def __post_init__(self):
        for name in ("width_px", "height_px", "width_cm", "height_cm", "distance_cm"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise RecordingError(f"screen {name} must be a positive number; got {v!r}")

    def px_per_cm(self) -> tuple[float, float]:
        return self.width_px / self.width_cm, self.height_px / self.height_cm

    def deg2px(self, x_deg, y_deg) -> tuple[np.ndarray, np.ndarray]:
        """Inverse of pymovements' pix2deg (origin upper left, y down; ``y_deg`` positive up)."""
        kx, ky = self.px_per_cm()
        x = (self.width_px - 1) / 2 + np.tan(np.radians(x_deg)) * self.distance_cm * kx
        y = (self.height_px - 1) / 2 - np.tan(np.radians(y_deg)) * self.distance_cm * ky
        return x, y


@dataclass
class Recording:
    """One eye's gaze: ``times_ms``, ``x_deg``, ``y_deg`` (NaN in blinks / track loss; y up),
    ``rate_hz``; ``blinks_ms`` (start, end) pairs; ``file_saccades_ms``: the file's own saccade events
    (start, end) or ``None`` where it had none."""

    path: Path
    fmt: str
    times_ms: np.ndarray
    x_deg: np.ndarray
    y_deg: np.ndarray
    rate_hz: float
    blinks_ms: list = field(default_factory=list)
    file_saccades_ms: list | None = None
    screen: Screen | None = None
    units: str = "deg"
    gaze: object = None  #: the pymovements ``Gaze`` (positions in degrees)

    @property
    def name(self) -> str:
        return self.path.name

    @property
    def noise_deg(self) -> float:
        """Tracker noise (deg, per axis): robust SD (1.4826 MAD) of the sample-to-sample differences
        between samples slower than 30 deg/s, / sqrt(2)."""
        still = speed_deg_s(self.x_deg, self.y_deg, 1000.0 / self.rate_hz) < THRESHOLD_DEG_S
        still = still[1:] & still[:-1]  # both samples of a difference at fixation, not in a saccade
        d = np.concatenate([np.diff(self.x_deg)[still], np.diff(self.y_deg)[still]])
        d = d[np.isfinite(d)]
        if not len(d):
            return 0.0
        return float(1.4826 * np.median(np.abs(d - np.median(d))) / math.sqrt(2.0))


# ---------------------------------------------------------------------------------------- reading
def _format_of(path: Path, fmt: str | None) -> str:
    if fmt is not None:
        if fmt not in FORMATS:
            raise RecordingError(f"unknown recording format {fmt!r}; choose one of {', '.join(FORMATS)}")
        return fmt
    try:
        return _SUFFIX_FORMAT[path.suffix.lower()]
    except KeyError:
        raise RecordingError(f"{path}: cannot tell the format from the suffix {path.suffix or '(none)'!r}; "
                             "use .asc (EyeLink) or .csv/.tsv (samples), or give --format asc|csv") from None


def _read_text(path: Path) -> str:
    """The file's text (``read_recording`` has checked that it exists and is not a folder)."""
    try:
        data = path.read_bytes()
    except OSError as e:
        raise RecordingError(f"cannot read {path}: {e.strerror or e}") from None
    if b"\x00" in data[:4096]:
        raise RecordingError(f"{path} is a binary file, not a text recording; convert an EyeLink .edf with "
                             "edf2asc first, or export samples as CSV")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def _pm_experiment(screen: Screen | None, rate_hz: float | None = None, resolution_from_file: bool = False):
    import pymovements as pm

    if screen is None:
        return pm.Experiment(sampling_rate=rate_hz)
    px = (None, None) if resolution_from_file else (screen.width_px, screen.height_px)
    return pm.Experiment(screen_width_px=px[0], screen_height_px=px[1], screen_width_cm=screen.width_cm,
                         screen_height_cm=screen.height_cm, distance_cm=screen.distance_cm, origin="upper left",
                         sampling_rate=rate_hz)


def _geometry_hint(kind: str) -> str:
    if kind == "asc":
        return ("give the screen's size and viewing distance: --screen WIDTH_CM HEIGHT_CM DISTANCE_CM "
                "(the resolution comes from the file's GAZE_COORDS)")
    return ("give the screen geometry: --screen WIDTH_PX HEIGHT_PX WIDTH_CM HEIGHT_CM DISTANCE_CM, "
            "or write the gaze in degrees (columns x_deg, y_deg)")


def _positions(gaze) -> np.ndarray:
    """pymovements' ``position`` column (x, y in degrees; a lost sample null) as an (n, 2) float array
    with NaN for what is missing, in one vectorised polars select."""
    import polars as pl

    col = pl.col("position")
    return gaze.samples.select(col.list.get(0, null_on_oob=True).cast(pl.Float64).alias("x"),
                               col.list.get(1, null_on_oob=True).cast(pl.Float64).alias("y")).to_numpy()


def _read_asc(path: Path, text: str, screen: Screen | None, screen_cm_only: bool) -> Recording:
    lines = text.splitlines()
    n_samples = sum(1 for ln in lines[:5000] if ln[:1].isdigit())
    if not any(ln.startswith("**") or ln.startswith("MSG") or ln.startswith("START") for ln in lines[:2000]) \
            or (n_samples == 0 and not any(ln.startswith("SAMPLES") for ln in lines)):
        raise RecordingError(f"{path} is not an EyeLink ASC file (no '**' header, MSG or START lines, or no samples); "
                             "give the edf2asc output, or --format csv for a CSV of samples")
    starts = [i for i, ln in enumerate(lines) if ln.startswith("START")]
    ends = [i for i, ln in enumerate(lines) if ln.startswith("END")]
    if not starts:
        raise RecordingError(f"{path}: no START line: not a recording block of an EyeLink ASC file")
    if not ends or ends[-1] < starts[-1]:
        raise RecordingError(f"{path} looks truncated: the recording block that starts on line {starts[-1] + 1} "
                             "has no END line (was the file cut short while copying or converting?)")
    if not text.endswith("\n"):
        raise RecordingError(f"{path} looks truncated: its last line is incomplete")
    if screen is None and any(ln.startswith("MSG") and "GAZE_COORDS" in ln for ln in lines[:5000]):
        raise RecordingError(f"{path}: the gaze is in pixels but the recording has no screen size or viewing "
                             f"distance; {_geometry_hint('asc')}")
    import pymovements as pm  # after the cheap checks: importing it takes seconds

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            gaze = pm.gaze.from_asc(path, events=True, encoding="latin-1",
                                    experiment=_pm_experiment(screen, resolution_from_file=screen_cm_only))
        except Exception as e:  # noqa: BLE001 -- pymovements/polars raise many kinds; name the file
            raise RecordingError(f"cannot parse {path} as EyeLink ASC: {str(e).splitlines()[0] if str(e) else type(e).__name__}") from None
    samples = gaze.samples
    if samples.height < 10 or "pixel" not in samples.columns:
        raise RecordingError(f"{path}: fewer than 10 gaze samples parsed; is it an ASC file with samples "
                             "(edf2asc without -e)?")
    meta = getattr(gaze, "_metadata", {}) or {}
    rate = gaze.experiment.eyetracker.sampling_rate or meta.get("sampling_rate")
    res = (gaze.experiment.screen.width_px, gaze.experiment.screen.height_px)
    if screen is None or None in res:
        what = "no GAZE_COORDS line (screen resolution)" if None in res else "no screen size or viewing distance"
        raise RecordingError(f"{path}: the gaze is in pixels but the recording has {what}; {_geometry_hint('asc' if None not in res else 'csv')}")
    if screen_cm_only:
        screen = Screen(int(res[0]), int(res[1]), screen.width_cm, screen.height_cm, screen.distance_cm)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gaze.pix2deg()
    times = samples["time"].cast(float).to_numpy()
    pos = _positions(gaze)
    x, y = pos[:, 0], -pos[:, 1]  # pymovements' y grows downward (screen rows); ours grows upward
    blinks, sacc = [], []
    if gaze.events is not None and gaze.events.frame.height:
        ev = gaze.events.frame
        for name, on, off in zip(ev["name"].to_list(), ev["onset"].to_list(), ev["offset"].to_list()):
            if name.startswith("blink"):
                blinks.append((float(on), float(off)))
            elif name.startswith("saccade"):
                sacc.append((float(on), float(off)))
    if not rate:
        rate = 1000.0 / float(np.median(np.diff(times)))
    return _finish(Recording(path, "asc", times, x, y, float(rate), blinks, sacc or None, screen, "px", gaze))


def _read_csv(path: Path, text: str, screen: Screen | None) -> Recording:
    first = text.split("\n", 1)[0]
    sep = "\t" if ("\t" in first and "," not in first) else ","
    header = [h.strip() for h in first.split(sep)]
    if "time_ms" not in header:
        raise RecordingError(f"{path} is not a CSV of samples: its header {first[:80]!r} has no time_ms column "
                             "(expected columns time_ms and x_deg, y_deg or x_px, y_px; an EyeLink file needs "
                             "--format asc)")
    if {"x_deg", "y_deg"} <= set(header):
        units, cols = "deg", ["x_deg", "y_deg"]
    elif {"x_px", "y_px"} <= set(header):
        units, cols = "px", ["x_px", "y_px"]
    else:
        raise RecordingError(f"{path}: the header {first[:80]!r} needs gaze columns x_deg, y_deg (degrees) or "
                             "x_px, y_px (pixels)")
    if units == "px" and screen is None:
        raise RecordingError(f"{path}: the gaze is in pixels (x_px, y_px) but no screen geometry was given; "
                             + _geometry_hint("csv"))
    if units == "px" and screen is not None and screen.width_px is None:
        raise RecordingError(f"{path}: a CSV in pixels needs the resolution too; " + _geometry_hint("csv"))
    rows = text.rstrip("\n").split("\n")
    if len(rows) > 1 and len(rows[-1].split(sep)) < len(header):
        raise RecordingError(f"{path} looks truncated: its last line ({len(rows)}) has {len(rows[-1].split(sep))} of "
                             f"{len(header)} fields")
    import polars as pl
    import pymovements as pm  # after the cheap checks: importing it takes seconds

    try:
        df = pl.read_csv(path, separator=sep, columns=["time_ms"] + cols, null_values=["", "nan", "NaN", "."],
                         schema_overrides={c: pl.Float64 for c in ["time_ms"] + cols}, comment_prefix="#")
    except Exception as e:  # noqa: BLE001 -- polars errors; name the file and the problem
        raise RecordingError(f"cannot parse {path} as a CSV of samples: {str(e).splitlines()[0]}") from None
    times = df["time_ms"].to_numpy().astype(float)
    if len(times) < 10:
        raise RecordingError(f"{path}: fewer than 10 samples")
    if not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
        raise RecordingError(f"{path}: time_ms must be finite and strictly increasing (sample {int(np.argmax(np.diff(times) <= 0)) + 2} is not)")
    rate = 1000.0 / float(np.median(np.diff(times)))
    df = df.with_columns(pl.col(c).fill_nan(None) for c in cols)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if units == "px":
            gaze = pm.Gaze(df, experiment=_pm_experiment(screen, rate), time_column="time_ms", time_unit="ms",
                           pixel_columns=cols)
            gaze.pix2deg()
        else:
            gaze = pm.Gaze(df, experiment=_pm_experiment(None, rate), time_column="time_ms", time_unit="ms",
                           position_columns=cols)
    pos = _positions(gaze)
    x, y = pos[:, 0], (-pos[:, 1] if units == "px" else pos[:, 1])
    return _finish(Recording(path, "csv", times, x, y, rate, [], None, screen, units, gaze))


def _finish(rec: Recording) -> Recording:
    dt = np.diff(rec.times_ms)
    if np.any(dt <= 0):
        raise RecordingError(f"{rec.path}: sample times go backwards or repeat (at {rec.times_ms[int(np.argmax(dt <= 0)) + 1]:g} ms): corrupt or concatenated file")
    if not np.any(np.isfinite(rec.x_deg)):
        raise RecordingError(f"{rec.path}: no valid gaze samples (all missing)")
    return rec


def read_recording(path, *, screen: Screen | None = None, fmt: str | None = None) -> Recording:
    """Read an EyeLink ASC file or a CSV/TSV of samples (see the module docstring) into degrees.

    ``screen`` gives the geometry for data in pixels; for an ASC file only its size and distance
    are used (the resolution is the file's ``GAZE_COORDS``). Raises :class:`RecordingError` naming
    the problem for anything unusable."""
    path = Path(path)
    if not path.exists():
        raise RecordingError(f"{path}: no such file")
    if path.is_dir():
        raise RecordingError(f"{path} is a folder; give a recording file (.asc or .csv)")
    kind = _format_of(path, fmt)
    text = _read_text(path)
    if not text.strip():
        raise RecordingError(f"{path} is empty")
    if kind == "asc":
        return _read_asc(path, text, screen, screen_cm_only=True)
    return _read_csv(path, text, screen)


# ---------------------------------------------------------------------------------------- measuring
def speed_deg_s(x: np.ndarray, y: np.ndarray | None, dt_ms: float) -> np.ndarray:
    """Eye speed (deg/s) by the five-point differentiator (pymovements' ``fivepoint``); NaN at the two
    samples of each end. ``y`` None: a one-dimensional trace."""
    def d(a):
        v = np.full(a.shape, np.nan)
        v[2:-2] = (a[4:] + a[3:-1] - a[1:-3] - a[:-4]) / (6.0 * dt_ms / 1000.0)
        return v

    return np.abs(d(x)) if y is None else np.hypot(d(x), d(y))


def _crossing(t, s, i, step) -> float | None:
    """Walk from the peak index ``i`` by ``step`` to the first sample below threshold; the crossing
    time interpolated linearly; None if the walk leaves the data or meets a NaN."""
    n = len(s)
    j = i
    while 0 <= j + step < n:
        k = j + step
        if not np.isfinite(s[k]):
            return None
        if s[k] < THRESHOLD_DEG_S:
            return float(t[j] + (t[k] - t[j]) * (s[j] - THRESHOLD_DEG_S) / (s[j] - s[k]))
        j = k
    return None


def measure_saccade(t: np.ndarray, s: np.ndarray, i_peak: int, rate_hz: float) -> tuple[float, float, float, float, float] | None:
    """Onset and offset (30 deg/s crossings), peak velocity, peak time and skewness of the saccade
    whose speed trace ``s`` (at times ``t``) peaks at sample ``i_peak``; None where a crossing is
    missing. The peak time is refined by a parabola through the top three samples."""
    on = _crossing(t, s, i_peak, -1)
    off = _crossing(t, s, i_peak, +1)
    if on is None or off is None or off <= on:
        return None
    pk = float(s[i_peak])
    tp = float(t[i_peak])
    if 0 < i_peak < len(s) - 1 and np.all(np.isfinite(s[i_peak - 1:i_peak + 2])):
        a, b, c = s[i_peak - 1], s[i_peak], s[i_peak + 1]
        den = a - 2 * b + c
        if den < 0:
            tp += 0.5 * (a - c) / den * (t[i_peak + 1] - t[i_peak])
    skew = (tp - on) / (off - on) if rate_hz >= SKEWNESS_MIN_RATE_HZ else math.nan
    return on, off, pk, tp, skew


def detect_saccades(rec: Recording, method: str = "auto", *, min_amplitude_deg: float = 1.0) -> list[tuple[int, int]]:
    """Candidate saccades as (first, last) sample indices: the file's own saccade events (``file``;
    ``auto`` uses them where the file has them) or pymovements' Engbert & Kliegl detection
    (``engbert``). Candidates within ``BLINK_MARGIN_MS`` of a blink or a missing sample are dropped.
    ``min_amplitude_deg`` drops microsaccades (by the span of gaze within the event)."""
    if method not in ("auto", "file", "engbert"):
        raise RecordingError(f"unknown detection method {method!r}; choose auto, file or engbert")
    t = rec.times_ms
    if method == "file" and rec.file_saccades_ms is None:
        raise RecordingError(f"{rec.path} has no saccade events of its own (ESACC); use --detect engbert")
    if method in ("file", "auto") and rec.file_saccades_ms:
        events = rec.file_saccades_ms
    else:
        events = _engbert(rec)
    bad = ~(np.isfinite(rec.x_deg) & np.isfinite(rec.y_deg))
    blink_iv = [(t[a], t[b]) for a, b in _runs(bad)] + list(rec.blinks_ms)
    out = []
    for on, off in events:
        lo, hi = on - BLINK_MARGIN_MS, off + BLINK_MARGIN_MS
        if any(b0 <= hi and b1 >= lo for b0, b1 in blink_iv):
            continue
        i0, i1 = int(np.searchsorted(t, on)), int(np.searchsorted(t, off, side="right")) - 1
        if i1 - i0 < 1:
            continue
        seg_x, seg_y = rec.x_deg[i0:i1 + 1], rec.y_deg[i0:i1 + 1]
        if math.hypot(np.ptp(seg_x), np.ptp(seg_y)) < min_amplitude_deg:
            continue
        out.append((i0, i1))
    return out


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) indices of the runs of True in ``mask``."""
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1))


def _engbert(rec: Recording) -> list[tuple[float, float]]:
    """pymovements' Engbert & Kliegl (2003) detection on its five-point velocity; (onset, offset) ms."""
    gaze = rec.gaze
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if "velocity" not in gaze.samples.columns:
            gaze.pos2vel(method="fivepoint")
        # minimum_duration is in the time column's unit (ms): 8 ms keeps 2-sample events out at 250 Hz
        try:
            gaze.detect("microsaccades", minimum_duration=8, clear=True)
        except ValueError:  # a noise-free trace: the median-based threshold is 0; use a fixed 5 deg/s per axis
            gaze.detect("microsaccades", minimum_duration=8, clear=True, threshold=(5.0, 5.0))
    ev = gaze.events.frame
    return [(float(a), float(b)) for a, b in zip(ev["onset"].to_list(), ev["offset"].to_list())]


def main_sequence_rows(rec: Recording, saccades: list[tuple[int, int]] | None = None) -> list[dict]:
    """One row per measurable saccade (``ROW_FIELDS``): amplitude, duration, peak velocity, direction,
    skewness (module docstring). ``saccades`` defaults to :func:`detect_saccades`."""
    if saccades is None:
        saccades = detect_saccades(rec)
    t, x, y = rec.times_ms, rec.x_deg, rec.y_deg
    dt = 1000.0 / rec.rate_hz
    s = speed_deg_s(x, y, dt)
    rows = []
    bounds = [(t[a], t[b]) for a, b in saccades]
    for k, (i0, i1) in enumerate(saccades):
        pad = int(math.ceil(10.0 / dt)) + 2
        lo, hi = max(i0 - pad, 0), min(i1 + pad, len(t) - 1)
        seg = s[lo:hi + 1]
        if not np.any(np.isfinite(seg)):
            continue
        ip = lo + int(np.nanargmax(seg))
        m = measure_saccade(t, s, ip, rec.rate_hz)
        if m is None:
            continue
        on, off, pk, tp, skew = m
        prev_end = bounds[k - 1][1] if k else -np.inf
        next_start = bounds[k + 1][0] if k + 1 < len(bounds) else np.inf
        pre = (t >= max(on - PRE_WINDOW_MS[0], prev_end)) & (t <= on - PRE_WINDOW_MS[1])
        post = (t >= off + POST_WINDOW_MS[0]) & (t <= min(off + POST_WINDOW_MS[1], next_start))
        if pre.sum() < 2 or post.sum() < 2:
            continue
        x0, y0, x1, y1 = (float(np.nanmedian(v[w])) for v, w in ((x, pre), (y, pre), (x, post), (y, post)))
        if not all(map(math.isfinite, (x0, y0, x1, y1))):
            continue
        rows.append({"saccade": len(rows) + 1, "onset_ms": round(on, 2), "amplitude_deg": round(math.hypot(x1 - x0, y1 - y0), 4),
                     "duration_ms": round(off - on, 3), "peak_velocity_deg_s": round(pk, 2),
                     "direction_deg": round(math.degrees(math.atan2(y1 - y0, x1 - x0)), 2),
                     "skewness": round(skew, 4) if math.isfinite(skew) else math.nan})
    return rows


def write_rows(rows: list[dict], path) -> None:
    """The main-sequence rows as a CSV (columns ``ROW_FIELDS``), written atomically."""
    from .folders import write_csv

    write_csv(path, list(ROW_FIELDS), rows)


# ---------------------------------------------------------------------------------------- writing
def write_recording(path, times_ms, x_deg, y_deg, *, fmt: str = "asc", rate_hz: float, screen: Screen | None = None,
                    blinks=(), saccades=(), units: str = "px", seed: int = 0) -> Path:
    """Write gaze (degrees, y up; NaN = track loss) as an EyeLink ASC file or a CSV of samples.

    ASC: an ``edf2asc``-like file (header, ``GAZE_COORDS``, ``SAMPLES GAZE LEFT RATE``, monocular
    left-eye samples ``time x y pupil ...``, ``.`` for lost samples, ``SBLINK/EBLINK`` for
    ``blinks`` and ``SSACC/ESACC`` for ``saccades``, (start, end) ms pairs). CSV: columns
    ``time_ms,x_px,y_px`` (``units='px'``) or ``time_ms,x_deg,y_deg`` (``units='deg'``), empty cells
    for lost samples. ``screen`` defaults to 1920 x 1080 px, 60 x 33.75 cm at 57 cm."""
    path = Path(path)
    screen = screen or Screen(1920, 1080, 60.0, 33.75, 57.0)
    t = np.asarray(times_ms, float)
    x, y = np.asarray(x_deg, float), np.asarray(y_deg, float)
    if fmt == "csv":
        if units not in ("px", "deg"):
            raise ValueError(f"units must be 'px' or 'deg'; got {units!r}")
        a, b, digits = (x, y, 4) if units == "deg" else (*screen.deg2px(x, y), 2)

        def cell(v: float) -> str:
            return f"{v:.{digits}f}" if math.isfinite(v) else ""  # empty: a lost sample

        with open(path, "w") as f:
            f.write(f"time_ms,x_{units},y_{units}\n")
            f.writelines(f"{ti:.2f},{cell(ai)},{cell(bi)}\n" for ti, ai, bi in zip(t, a, b))
        return path
    if fmt != "asc":
        raise ValueError(f"fmt must be 'asc' or 'csv'; got {fmt!r}")
    px, py = screen.deg2px(x, y)
    rng = np.random.default_rng(seed)
    integral = np.allclose(t, np.round(t))
    tf = (lambda v: f"{int(round(v))}") if integral else (lambda v: f"{v:.1f}")
    events = []  # (time, order, line)
    for b0, b1 in blinks:
        events.append((b0, 0, f"SBLINK L {tf(b0)}"))
        events.append((b1, 2, f"EBLINK L {tf(b0)}\t{tf(b1)}\t{int(round(b1 - b0 + 1000 / rate_hz))}"))
    for s0, s1 in saccades:
        i0, i1 = int(np.searchsorted(t, s0)), min(int(np.searchsorted(t, s1)), len(t) - 1)
        amp = math.hypot(x[i1] - x[i0], y[i1] - y[i0])
        sp = speed_deg_s(x[max(i0 - 3, 0):i1 + 4], y[max(i0 - 3, 0):i1 + 4], 1000.0 / rate_hz)
        events.append((s0, 1, f"SSACC L  {tf(s0)}"))
        events.append((s1, 3, f"ESACC L  {tf(s0)}\t{tf(s1)}\t{int(round(s1 - s0 + 1000 / rate_hz))}\t{px[i0]:7.1f}\t"
                              f"{py[i0]:7.1f}\t{px[i1]:7.1f}\t{py[i1]:7.1f}\t{amp:6.2f}\t{np.nanmax(sp):7.0f}"))
    events.sort(key=lambda e: (e[0], e[1]))
    w, h = screen.width_px, screen.height_px
    t0 = t[0]
    head = [
        f"** CONVERTED FROM {path.with_suffix('.edf').name} using edfapi 4.2.1 Apr  2 2020",
        "** DATE: Wed Mar  8 09:25:20 2023",
        "** TYPE: EDF_FILE BINARY EVENT SAMPLE TAGGED",
        "** VERSION: EYELINK II 1",
        "** SOURCE: EYELINK CL",
        "** EYELINK II CL v6.12 Feb  1 2018 (EyeLink Portable Duo)",
        "** CAMERA: EyeLink USBCAM Version 1.01",
        "** SERIAL NUMBER: CLU-DAB50",
        "** CAMERA_CONFIG: DAB50200.SCD",
        "** RECORDED BY conformal-head experiments.eyetracking.write_recording",
        "**",
        "",
        f"MSG\t{tf(t0 - 10)} DISPLAY_COORDS 0 0 {w - 1} {h - 1}",
        f"MSG\t{tf(t0 - 10)} RECCFG CR {int(round(rate_hz))} 2 1 L",
        f"MSG\t{tf(t0 - 10)} ELCLCFG BTABLER",
        f"MSG\t{tf(t0 - 10)} GAZE_COORDS 0.00 0.00 {w - 1:.2f} {h - 1:.2f}",
        f"START\t{tf(t0)} \tLEFT\tSAMPLES\tEVENTS",
        "PRESCALER\t1",
        "VPRESCALER\t1",
        "PUPIL\tAREA",
        f"EVENTS\tGAZE\tLEFT\tRATE\t{rate_hz:7.2f}\tTRACKING\tCR\tFILTER\t2",
        f"SAMPLES\tGAZE\tLEFT\tRATE\t{rate_hz:7.2f}\tTRACKING\tCR\tFILTER\t2",
    ]
    pupil = 800.0 + rng.normal(0, 5, len(t))
    out = head
    e = 0
    for i in range(len(t)):
        while e < len(events) and events[e][0] <= t[i] and events[e][1] in (0, 1):
            out.append(events[e][2])
            e += 1
        if math.isfinite(px[i]) and math.isfinite(py[i]):
            out.append(f"{tf(t[i])}\t{px[i]:7.1f}\t{py[i]:7.1f}\t{pupil[i]:7.1f}\t...")
        else:
            out.append(f"{tf(t[i])}\t   .\t   .\t    0.0\t...")
        while e < len(events) and events[e][0] <= t[i]:
            out.append(events[e][2])
            e += 1
    out += [ev[2] for ev in events[e:]]
    out.append(f"END\t{tf(t[-1] + 1)} \tSAMPLES\tEVENTS\tRES\t  38.54\t  31.12")
    path.write_text("\n".join(out) + "\n")
    return path


def synthetic_session(generator=None, *, n_saccades: int = 60, rate_hz: float = 500.0, noise_deg: float = 0.02,
                      n_blinks: int = 3, amplitudes=(2.0, 30.0), seed: int = 0, t0_ms: float = 1_000_000.0):
    """A recording made from the generator's own traces (nominal plant): ``n_saccades`` saccades of
    uniformly drawn amplitudes in random directions (kept within +-20 x +-12 deg), fixations of
    300-600 ms between them, Gaussian tracker noise, and ``n_blinks`` 100-200 ms blinks in
    fixations (NaN samples). Returns ``dict(times_ms, x_deg, y_deg, blinks, saccades, amplitudes,
    directions)``: ``saccades`` are (start, end) ms of each movement (30 deg/s crossings)."""
    import models

    gen = generator or models.BurstGenerator()
    rng = np.random.default_rng(seed)
    dt = 1000.0 / rate_hz
    plan = []  # (burst onset ms, amplitude, direction rad, start x, start y)
    px, py, tcur = 0.0, 0.0, 300.0
    for _ in range(n_saccades):
        a = float(rng.uniform(*amplitudes))
        for _try in range(100):
            th = float(rng.uniform(-math.pi, math.pi))
            ex, ey = px + a * math.cos(th), py + a * math.sin(th)
            if abs(ex) <= 20 and abs(ey) <= 12:
                break
        else:
            th = math.atan2(-py, -px)
            ex, ey = px + a * math.cos(th), py + a * math.sin(th)
        plan.append((tcur, a, th, px, py))
        px, py = ex, ey
        tcur += float(rng.uniform(300, 600)) + 2.2 * a + 30
    total = tcur + 300.0
    t = np.arange(0.0, total, dt)
    x, y = np.zeros_like(t), np.zeros_like(t)
    sacc = []
    for k, (ts, a, th, sx, sy) in enumerate(plan):
        end = plan[k + 1][0] if k + 1 < len(plan) else total
        m = (t >= ts) & (t < end) if k else (t < end)
        prof = gen.profile(a)
        p = prof.position(np.maximum(t[m] - ts, -1.0))
        x[m], y[m] = sx + a * math.cos(th) * p, sy + a * math.sin(th) * p
        sacc.append((ts + prof.onset_ms, ts + prof.onset_ms + prof.duration_ms))
    x += rng.normal(0, noise_deg, len(t))
    y += rng.normal(0, noise_deg, len(t))
    blinks = []
    for b in rng.choice(len(plan) - 1, size=min(n_blinks, len(plan) - 1), replace=False) if n_blinks else []:
        ts = sacc[b][1] + 60.0
        b0, b1 = ts, ts + float(rng.uniform(100, 200))
        if b1 + 60 < plan[b + 1][0]:
            m = (t >= b0) & (t <= b1)
            x[m], y[m] = np.nan, np.nan
            blinks.append((float(t[m][0]), float(t[m][-1])))
    # snap event times to samples
    sacc_s = [(float(t[np.searchsorted(t, a)]), float(t[min(np.searchsorted(t, b), len(t) - 1)])) for a, b in sacc]
    return dict(times_ms=t + t0_ms, x_deg=x, y_deg=y, blinks=[(a + t0_ms, b + t0_ms) for a, b in blinks],
                saccades=[(a + t0_ms, b + t0_ms) for a, b in sacc_s], amplitudes=np.array([p[1] for p in plan]),
                directions=np.degrees([p[2] for p in plan]))
