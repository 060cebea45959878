"""Eye-tracker recordings in: samples, blinks and saccades out, and a person's main sequence.

``python -m experiments saccades --recording FILE --out DIR`` reads a recording with
:func:`read_recording`, finds its saccades with :func:`detect_saccades`, measures them with
:func:`main_sequence_rows` (``main_sequence.csv``), checks that they are plausible
(:func:`check_plausible`) and fits the burst generator to them (``experiments.oculomotor.generator_fit``).

Formats (the docs' eye-tracker page, ``docs/eyetracker.md``, has the details): **EyeLink ASC**
(``experiments.oculomotor.asc``: monocular or binocular, remote mode, 250-2000 Hz, any number of
blocks; one eye measured, the reason in ``Recording.eye_reason``) and **CSV/TSV of samples**
(``experiments.oculomotor.tables``: named columns or a preset; ms, µs or s; degrees or pixels).

Missing data split the trace: no velocity is computed across a block boundary, a pause (a step
longer than 1.25 sampling periods) or a lost sample (``experiments.oculomotor.kinematics``), so
no saccade is measured across one; saccades within ``BLINK_MARGIN_MS`` of missing data are dropped.

Screen geometry: ``Screen(width_px, height_px, width_cm, height_cm, distance_cm)`` (``width_px``
None: from the file); pixels are converted to degrees per axis as pymovements' ``pix2deg`` does:
``atan`` of the centred pixel distance over the viewing distance in pixels.

Measures (:func:`main_sequence_rows`; the velocity and the crossings are
``experiments.oculomotor.kinematics``, the one measure that the generator fit also applies to the
model's traces): duration between the 30 deg/s crossings of the Savitzky--Golay speed around its
peak; peak velocity the largest speed between them; amplitude the distance between the median
gaze 4-20 ms before the onset crossing and 20-40 ms after the offset crossing (clipped to the
neighbouring saccades and to the trace's unbroken stretch); direction ``atan2(dy, dx)`` in
degrees, 0 rightward, 90 upward; skewness the time of peak velocity as a fraction of the duration
(NaN below ``SKEWNESS_MIN_RATE_HZ``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .asc import AscError, parse_asc
from .kinematics import SKEWNESS_MIN_RATE_HZ, THRESHOLD_DEG_S, engbert_kliegl, measure_saccade, speed_deg_s, steps_ok
from .tables import PRESETS, TIME_UNITS, Columns, TableError, decode, read_table

__all__ = [
    "Screen",
    "Recording",
    "RecordingError",
    "read_recording",
    "read_recordings",
    "detect_saccades",
    "measure_saccade",
    "main_sequence_rows",
    "check_plausible",
    "write_recording",
    "speed_deg_s",
    "synthetic_session",
    "FORMATS",
    "SKEWNESS_MIN_RATE_HZ",
    "BLINK_MARGIN_MS",
    "ROW_FIELDS",
    "EYE_CHOICES",
    "MAX_PLAUSIBLE_VELOCITY_DEG_S",
    "PRESETS",
]

FORMATS = ("asc", "csv")
EYE_CHOICES = ("left", "right", "both")
BLINK_MARGIN_MS = 20.0
PRE_WINDOW_MS = (20.0, 4.0)  # median gaze this long before the onset crossing (from, to)
POST_WINDOW_MS = (20.0, 40.0)  # ... and after the offset crossing
#: No human saccade is faster (the fastest reported, ~700-800 deg/s for 40-60 deg saccades:
#: Collewijn, Erkelens & Steinman 1988, Fig. 6; Boghen et al. 1974); a faster one is an artefact.
MAX_PLAUSIBLE_VELOCITY_DEG_S = 1000.0
#: Share of implausible saccades above which the recording itself is refused (below: they are dropped).
MAX_IMPLAUSIBLE_SHARE = 0.1
PAUSE_PERIODS = 1.25
ROW_FIELDS = ("saccade", "onset_ms", "amplitude_deg", "duration_ms", "peak_velocity_deg_s", "direction_deg", "skewness")
_SUFFIX_FORMAT = {".asc": "asc", ".csv": "csv", ".tsv": "csv", ".txt": "csv"}
_SCREEN_RANGES = {
    "width_px": (16, 100_000),
    "height_px": (16, 100_000),
    "width_cm": (1.0, 2000.0),
    "height_cm": (1.0, 2000.0),
    "distance_cm": (5.0, 2000.0),
}


class RecordingError(ValueError):
    """A recording that cannot be used, with a message naming the file and the problem."""


@dataclass(frozen=True)
class Screen:
    """Screen geometry: resolution (px; None: from the recording), visible size (cm) and viewing
    distance (cm). Values outside ``_SCREEN_RANGES`` (a 5 cm viewing distance, a 1e-300 one) are
    refused: they are typing errors, and would give degrees that mean nothing."""

    width_px: int | None
    height_px: int | None
    width_cm: float
    height_cm: float
    distance_cm: float

    def __post_init__(self):
        for name, (lo, hi) in _SCREEN_RANGES.items():
            v = getattr(self, name)
            if v is None and name.endswith("_px"):
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not lo <= v <= hi:
                raise RecordingError(f"screen {name} must be a number in [{lo:g}, {hi:g}]; got {v!r}")
            if name.endswith("_px") and v != int(v):
                raise RecordingError(f"screen {name} must be a whole number of pixels; got {v!r}")
        if (self.width_px is None) != (self.height_px is None):
            raise RecordingError("screen width_px and height_px go together (both given, or both from the file)")

    def with_resolution(self, width_px: int, height_px: int) -> Screen:
        return Screen(int(width_px), int(height_px), self.width_cm, self.height_cm, self.distance_cm)

    def _size_px(self) -> tuple[int, int]:
        """The resolution (width, height) in pixels; :class:`RecordingError` while it is still to come
        from a recording (``width_px``/``height_px`` None)."""
        if self.width_px is None or self.height_px is None:
            raise RecordingError(
                "this screen has no resolution yet (width_px, height_px None: from the recording); "
                "give it, or take the file's with Screen.with_resolution(width_px, height_px)"
            )
        return self.width_px, self.height_px

    def px_per_cm(self) -> tuple[float, float]:
        w, h = self._size_px()
        return w / self.width_cm, h / self.height_cm

    def px2deg(self, x_px, y_px) -> tuple[np.ndarray, np.ndarray]:
        """Pixels (origin upper left, y down) to degrees (y up), per axis, as pymovements' ``pix2deg``."""
        kx, ky = self.px_per_cm()
        w, h = self._size_px()
        x = np.degrees(np.arctan2(np.asarray(x_px, float) - (w - 1) / 2, self.distance_cm * kx))
        y = -np.degrees(np.arctan2(np.asarray(y_px, float) - (h - 1) / 2, self.distance_cm * ky))
        return x, y

    def deg2px(self, x_deg, y_deg) -> tuple[np.ndarray, np.ndarray]:
        """Inverse of :meth:`px2deg`."""
        kx, ky = self.px_per_cm()
        w, h = self._size_px()
        x = (w - 1) / 2 + np.tan(np.radians(x_deg)) * self.distance_cm * kx
        y = (h - 1) / 2 - np.tan(np.radians(y_deg)) * self.distance_cm * ky
        return x, y

    def extent_deg(self) -> tuple[float, float]:
        """Width and height of the screen in degrees (edge to edge, from its centre)."""
        return (
            2 * math.degrees(math.atan2(self.width_cm / 2, self.distance_cm)),
            2 * math.degrees(math.atan2(self.height_cm / 2, self.distance_cm)),
        )


@dataclass
class Recording:
    """One eye's gaze: ``times_ms``, ``x_deg``, ``y_deg`` (NaN in blinks / track loss; y up),
    ``rate_hz``; ``block``: each sample's recording block (START/END block of an ASC file, stretch
    between pauses of a table); ``blinks_ms`` (start, end) pairs; ``file_saccades_ms``: the file's own
    saccade events of this eye or ``None``; ``eye`` and why it was chosen."""

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
    eye: str = "left"
    eye_reason: str = ""
    block: np.ndarray | None = None
    notes: list = field(default_factory=list)

    @property
    def name(self) -> str:
        return self.path.name

    @property
    def dt_ms(self) -> float:
        return 1000.0 / self.rate_hz

    @property
    def ok_steps(self) -> np.ndarray:
        """(n - 1,) steps a velocity may span (``kinematics.steps_ok``)."""
        return steps_ok(self.times_ms, self.dt_ms, self.block)

    @property
    def n_blocks(self) -> int:
        """Unbroken stretches of samples (blocks and pauses; lost samples not counted)."""
        return int(1 + np.count_nonzero(~self.ok_steps))

    def speed(self) -> np.ndarray:
        return speed_deg_s(self.x_deg, self.y_deg, self.dt_ms, self.ok_steps)

    @property
    def noise_deg(self) -> float:
        """Tracker noise (deg, per axis): robust SD (1.4826 MAD) of the sample-to-sample differences
        between samples slower than 30 deg/s (inside unbroken stretches), / sqrt(2)."""
        still = self.speed() < THRESHOLD_DEG_S
        still = still[1:] & still[:-1] & self.ok_steps
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
        raise RecordingError(
            f"{path}: cannot tell the format from the suffix {path.suffix or '(none)'!r}; "
            "use .asc (EyeLink) or .csv/.tsv (samples), or give --format asc|csv"
        ) from None


def _read_text(path: Path) -> str:
    """The file's text, decoded (``oculomotor.tables.decode``: BOM, UTF-16, latin-1)."""
    try:
        data = path.read_bytes()
    except OSError as e:
        raise RecordingError(f"cannot read {path}: {e.strerror or e}") from None
    try:
        return decode(data, str(path))
    except TableError as e:
        raise RecordingError(str(e)) from None


def _choose_eye(path: Path, have: dict, eye: str | None) -> tuple[str, str]:
    """The eye to measure among ``have`` ({eye: x array}) and why."""
    names = [e for e in ("left", "right") if e in have] or list(have)
    if eye is not None and eye != "both":
        if eye not in have:
            if names == ["gaze"]:
                raise RecordingError(
                    f"{path}: its gaze columns do not say which eye they are; leave out --eye "
                    "(or name a column of L/R with --columns ...,eye=NAME)"
                )
            raise RecordingError(
                f"{path}: no {eye} eye in this recording (it has {' and '.join(names)}); give --eye {names[0]}"
            )
        return eye, "chosen with --eye"
    if len(names) == 1:
        return names[0], ("the only eye recorded" if names[0] != "gaze" else "one gaze column")
    lost = {e: float(np.mean(~np.isfinite(have[e]))) for e in names}
    best = min(names, key=lambda e: (lost[e], e != "left"))
    other = [e for e in names if e != best][0]
    return best, (
        f"binocular file: the eye with fewer lost samples ({100 * lost[best]:.1f} % vs "
        f"{100 * lost[other]:.1f} % for the {other}; --eye both measures each)"
    )


def _asc_recordings(path: Path, text: str, screen: Screen | None, eye: str | None) -> list[Recording]:
    if not any(ln.startswith(("**", "MSG", "START")) for ln in text.splitlines()[:5000]):
        raise RecordingError(
            f"{path} is not an EyeLink ASC file (no '**' header, MSG or START lines); "
            "give the edf2asc output, or --format csv for a CSV of samples"
        )
    if not text.endswith("\n"):
        raise RecordingError(f"{path} looks truncated: its last line is incomplete")
    try:
        data = parse_asc(text, str(path))
    except AscError as err:
        msg = str(err)
        raise RecordingError(msg if msg.startswith(str(path)) else f"{path}: {msg}") from None
    res = data.resolution
    if screen is None:
        need = "WIDTH_CM HEIGHT_CM DISTANCE_CM" if res else "WIDTH_PX HEIGHT_PX WIDTH_CM HEIGHT_CM DISTANCE_CM"
        why = (
            f"(the resolution comes from the file's {data.resolution_source})"
            if res
            else "(the file has no GAZE_COORDS or DISPLAY_COORDS line, so the resolution too)"
        )
        raise RecordingError(
            f"{path}: the gaze is in pixels but the recording has no screen size or viewing "
            f"distance; give them: --screen {need} {why}"
        )
    if res is None and screen.width_px is None:
        raise RecordingError(
            f"{path}: no GAZE_COORDS or DISPLAY_COORDS line, so the screen's resolution is unknown; "
            "give all five numbers: --screen WIDTH_PX HEIGHT_PX WIDTH_CM HEIGHT_CM DISTANCE_CM"
        )
    if res is not None and screen.width_px is not None and (screen.width_px, screen.height_px) != tuple(res):
        raise RecordingError(
            f"{path}: --screen gives {screen.width_px} x {screen.height_px} px but the file's "
            f"{data.resolution_source} says {res[0]} x {res[1]}; give the three numbers "
            "WIDTH_CM HEIGHT_CM DISTANCE_CM to use the file's"
        )
    scr = screen.with_resolution(*res) if res is not None else screen
    notes = [
        f"resolution {scr.width_px} x {scr.height_px} px from "
        f"{data.resolution_source if res is not None else '--screen'}"
    ]
    if data.remote:
        notes.append("remote mode (HTARGET)")
    eyes = list(data.eyes) if eye == "both" else [_choose_eye(path, data.x_px, eye)[0]]
    out = []
    for e in eyes:
        reason = "--eye both" if eye == "both" else _choose_eye(path, data.x_px, eye)[1]
        x, y = scr.px2deg(data.x_px[e], data.y_px[e])
        ev = [(k, a, b) for k, ee, a, b in data.events if ee == e]
        blinks = [(a, b) for k, a, b in ev if k == "blink"]
        sacc = [(a, b) for k, a, b in ev if k == "saccade"]
        rec = Recording(
            path,
            "asc",
            data.times_ms,
            x,
            y,
            data.rate_hz,
            blinks,
            sacc or None,
            scr,
            "px",
            e,
            reason,
            data.block,
            list(notes),
        )
        out.append(_finish(rec))
    return out


def _table_recordings(
    path: Path,
    text: str,
    screen: Screen | None,
    eye: str | None,
    columns: Columns | None,
    preset: str | None,
    time_unit: str | None,
    units: str | None,
) -> list[Recording]:
    try:
        tab = read_table(text, str(path), columns, preset)
    except TableError as err:
        msg = str(err)
        raise RecordingError(msg if msg.startswith(str(path)) else f"{path}: {msg}") from None
    tu = time_unit or tab.time_unit
    un = units or tab.units
    col = tab.columns
    if tu is None:
        tu = "ms"
    if tu not in TIME_UNITS:
        raise RecordingError(f"unknown time unit {tu!r}; choose one of {', '.join(TIME_UNITS)}")
    if un is None:
        raise RecordingError(
            f"{path}: cannot tell whether {col.x!r} is in pixels or degrees; give --units px or --units deg"
        )
    if un not in ("px", "deg"):
        raise RecordingError(f"unknown gaze unit {un!r}; choose px or deg")
    if col.fraction and un != "px":
        raise RecordingError(
            f"{path}: the gaze ({col.x}, {col.y}) is a fraction of the screen, read through its pixels: "
            "it cannot be in degrees; leave --units out (or give --units px) and give --screen"
        )
    if un == "px" and (screen is None or screen.width_px is None):
        raise RecordingError(
            f"{path}: the gaze is in pixels ({col.x}, {col.y}) but no screen geometry was given; give "
            "the screen geometry: --screen WIDTH_PX HEIGHT_PX WIDTH_CM HEIGHT_CM DISTANCE_CM, or "
            "write the gaze in degrees (columns x_deg, y_deg)"
        )
    have = tab.x
    chosen = list(have) if eye == "both" else [_choose_eye(path, have, eye)[0]]
    out = []
    for e in chosen:
        reason = "--eye both" if eye == "both" else _choose_eye(path, have, eye)[1]
        t = tab.time[e] * TIME_UNITS[tu]
        x, y = tab.x[e], tab.y[e]
        if len(t) < 10:
            raise RecordingError(f"{path}: fewer than 10 samples")
        if not np.all(np.isfinite(t)):
            raise RecordingError(
                f"{path}: the time column {col.time!r} has a missing value (sample "
                f"{int(np.argmax(~np.isfinite(t))) + 1})"
            )
        d = np.diff(t)
        if np.any(d <= 0):
            i = int(np.argmax(d <= 0)) + 1
            raise RecordingError(
                f"{path}: the time column {col.time!r} must increase strictly; sample {i + 1} "
                f"({tab.time[e][i]:g}) does not: corrupt or concatenated file"
            )
        period = float(np.median(d))
        rate = 1000.0 / period
        if not 20.0 <= rate <= 10_000.0:
            guess = {
                r: u
                for u, r in (("us", rate * 1000.0), ("s", rate / 1000.0), ("ms", rate * TIME_UNITS[tu]))
                if 20.0 <= r <= 10_000.0
            }
            hint = (
                (
                    f"; is the time in {', '.join(sorted(set(guess.values())))}? give --time-unit "
                    f"{next(iter(guess.values()))}"
                )
                if guess
                else ""
            )
            raise RecordingError(
                f"{path}: the median sample interval is {period:g} ms ({rate:.3g} Hz) with the time in "
                f"{tu}: no eye tracker samples at that rate{hint}"
            )
        if un == "px":
            assert screen is not None, "gaze in pixels was refused above without a screen"
            if col.fraction:
                w, h = screen._size_px()
                x, y = x * w, y * h
            x, y = screen.px2deg(x, y)
        block = np.concatenate([[0], np.cumsum(d > PAUSE_PERIODS * period)])
        rec = Recording(
            path,
            "csv",
            t,
            x,
            y,
            rate,
            [],
            None,
            screen,
            un,
            e if e != "gaze" else "unnamed",
            reason,
            block,
            [f"columns {col.time}, {col.x}, {col.y} ({col.source or 'named'}); time in {tu}"],
        )
        out.append(_finish(rec))
    return out


def _finish(rec: Recording) -> Recording:
    if not np.any(np.isfinite(rec.x_deg) & np.isfinite(rec.y_deg)):
        raise RecordingError(f"{rec.path}: no valid gaze samples of the {rec.eye} eye (all missing)")
    return rec


def read_recordings(
    path,
    *,
    screen: Screen | None = None,
    fmt: str | None = None,
    eye: str | None = None,
    columns: Columns | None = None,
    preset: str | None = None,
    time_unit: str | None = None,
    units: str | None = None,
) -> list[Recording]:
    """Read an EyeLink ASC file or a CSV/TSV of samples (module docstring) into degrees: one
    :class:`Recording` per eye measured (``eye='both'``: each eye recorded; else one). Raises
    :class:`RecordingError` naming the problem for anything unusable."""
    path = Path(path)
    if eye is not None and eye not in EYE_CHOICES:
        raise RecordingError(f"unknown eye {eye!r}; choose left, right or both")
    if not path.exists():
        raise RecordingError(f"{path}: no such file")
    if path.is_dir():
        raise RecordingError(f"{path} is a folder; give a recording file (.asc or .csv)")
    kind = _format_of(path, fmt)
    text = _read_text(path)
    if not text.strip():
        raise RecordingError(f"{path} is empty")
    if kind == "asc":
        if columns is not None or preset is not None or time_unit is not None or units is not None:
            raise RecordingError(
                f"{path}: --columns, --preset, --time-unit and --units are for CSV/TSV files; an ASC "
                "file says its own layout"
            )
        return _asc_recordings(path, text, screen, eye)
    first = next((ln for ln in text.splitlines() if ln.strip() and not ln.startswith("#")), "")
    if first.startswith("**") or first.startswith("MSG"):
        raise RecordingError(f"{path} is not a CSV of samples: it looks like an EyeLink ASC file; give --format asc")
    return _table_recordings(path, text, screen, eye, columns, preset, time_unit, units)


def read_recording(path, **kw) -> Recording:
    """:func:`read_recordings` of one eye (``eye`` left, right or None for the default choice)."""
    if kw.get("eye") == "both":
        raise RecordingError("read_recording reads one eye; use read_recordings for eye='both'")
    return read_recordings(path, **kw)[0]


# ---------------------------------------------------------------------------------------- measuring
def detect_saccades(rec: Recording, method: str = "auto", *, min_amplitude_deg: float = 1.0) -> list[tuple[int, int]]:
    """Candidate saccades as (first, last) sample indices: the file's own saccade events of the eye
    (``file``; ``auto`` uses them where the file has them) or Engbert & Kliegl detection
    (``engbert``, ``oculomotor.kinematics.engbert_kliegl``). Candidates within ``BLINK_MARGIN_MS`` of
    a blink, a missing sample or a gap (block boundary, pause) are dropped, as are those spanning a
    gap. ``min_amplitude_deg`` drops microsaccades (by the span of gaze within the event)."""
    if method not in ("auto", "file", "engbert"):
        raise RecordingError(f"unknown detection method {method!r}; choose auto, file or engbert")
    t = rec.times_ms
    if method == "file" and rec.file_saccades_ms is None:
        raise RecordingError(
            f"{rec.path} has no saccade events of its own (ESACC) for the {rec.eye} eye; use --detect engbert"
        )
    if method in ("file", "auto") and rec.file_saccades_ms:
        events = rec.file_saccades_ms
    else:
        events = engbert_kliegl(t, rec.x_deg, rec.y_deg, rec.dt_ms, rec.ok_steps)
    bad = ~(np.isfinite(rec.x_deg) & np.isfinite(rec.y_deg))
    gaps = np.flatnonzero(~rec.ok_steps)
    blink_iv = [(t[a], t[b]) for a, b in _runs(bad)] + list(rec.blinks_ms) + [(t[i], t[i + 1]) for i in gaps]
    iv = np.array(blink_iv, float).reshape(-1, 2)
    out = []
    for on, off in events:
        lo, hi = on - BLINK_MARGIN_MS, off + BLINK_MARGIN_MS
        if len(iv) and np.any((iv[:, 0] <= hi) & (iv[:, 1] >= lo)):
            continue
        i0, i1 = int(np.searchsorted(t, on)), int(np.searchsorted(t, off, side="right")) - 1
        if i1 - i0 < 1:
            continue
        seg_x, seg_y = rec.x_deg[i0 : i1 + 1], rec.y_deg[i0 : i1 + 1]
        if math.hypot(np.ptp(seg_x), np.ptp(seg_y)) < min_amplitude_deg:
            continue
        out.append((i0, i1))
    return out


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) indices of the runs of True in ``mask``."""
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1))


def main_sequence_rows(rec: Recording, saccades: list[tuple[int, int]] | None = None) -> list[dict]:
    """One row per measurable saccade (``ROW_FIELDS``): amplitude, duration, peak velocity, direction,
    skewness (module docstring). ``saccades`` defaults to :func:`detect_saccades`."""
    if saccades is None:
        saccades = detect_saccades(rec)
    t, x, y = rec.times_ms, rec.x_deg, rec.y_deg
    dt = rec.dt_ms
    ok = rec.ok_steps
    s = speed_deg_s(x, y, dt, ok)
    stretch = np.concatenate([[0], np.cumsum(~ok)])  # unbroken stretch of each sample
    rows: list[dict] = []
    peaks: set[int] = set()
    bounds = [(t[a], t[b]) for a, b in saccades]
    for k, (i0, i1) in enumerate(saccades):
        pad = int(math.ceil(10.0 / dt)) + 2
        lo, hi = max(i0 - pad, 0), min(i1 + pad, len(t) - 1)
        lo = max(lo, int(np.searchsorted(stretch, stretch[i0])))  # the search stays in the saccade's stretch
        hi = min(hi, int(np.searchsorted(stretch, stretch[i0], side="right")) - 1)
        seg = s[lo : hi + 1]
        if hi < lo or not np.any(np.isfinite(seg)):
            continue
        ip = lo + int(np.nanargmax(seg))
        if ip in peaks:  # two events of one movement
            continue
        m = measure_saccade(t, s, ip, rec.rate_hz)
        if m is None:
            continue
        on, off, pk, tp, skew = m
        prev_end = bounds[k - 1][1] if k else -np.inf
        next_start = bounds[k + 1][0] if k + 1 < len(bounds) else np.inf
        same = stretch == stretch[ip]
        pre = same & (t >= max(on - PRE_WINDOW_MS[0], prev_end)) & (t <= on - PRE_WINDOW_MS[1])
        post = same & (t >= off + POST_WINDOW_MS[0]) & (t <= min(off + POST_WINDOW_MS[1], next_start))
        if pre.sum() < 2 or post.sum() < 2:
            continue
        x0, y0, x1, y1 = (
            float(np.nanmedian(v[w])) if np.isfinite(v[w]).any() else math.nan
            for v, w in ((x, pre), (y, pre), (x, post), (y, post))
        )
        if not all(map(math.isfinite, (x0, y0, x1, y1))):
            continue
        peaks.add(ip)
        rows.append(
            {
                "saccade": len(rows) + 1,
                "onset_ms": round(on, 2),
                "amplitude_deg": round(math.hypot(x1 - x0, y1 - y0), 4),
                "duration_ms": round(off - on, 3),
                "peak_velocity_deg_s": round(pk, 2),
                "direction_deg": round(math.degrees(math.atan2(y1 - y0, x1 - x0)), 2),
                "skewness": round(skew, 4) if math.isfinite(skew) else math.nan,
            }
        )
    return rows


def check_plausible(rec: Recording, rows: list[dict]) -> tuple[list[dict], list[dict]]:
    """Split ``rows`` into plausible saccades and implausible ones (peak velocity above
    ``MAX_PLAUSIBLE_VELOCITY_DEG_S``, or an amplitude larger than the screen's diagonal -- 100 deg
    when no screen is known). When more than ``MAX_IMPLAUSIBLE_SHARE`` of them are implausible the
    recording is refused (:class:`RecordingError`) with the probable cause: pixels in degree columns,
    wrong screen geometry, or a wrong time unit."""
    if rec.screen is not None and rec.screen.width_px is not None:
        w, h = rec.screen.extent_deg()
        limit = math.hypot(w, h)
        where = f"the screen's diagonal ({limit:.0f} deg)"
    else:
        limit, where = 100.0, "100 deg"
    bad = [r for r in rows if r["peak_velocity_deg_s"] > MAX_PLAUSIBLE_VELOCITY_DEG_S or r["amplitude_deg"] > limit]
    good = [r for r in rows if r not in bad]
    if not rows or len(bad) <= MAX_IMPLAUSIBLE_SHARE * len(rows):
        return good, bad
    amp = float(np.median([r["amplitude_deg"] for r in bad]))
    pv = float(np.median([r["peak_velocity_deg_s"] for r in bad]))
    dur = float(np.median([r["duration_ms"] for r in bad]))
    span = float(np.nanmax(np.abs(np.concatenate([rec.x_deg, rec.y_deg]))))
    if rec.units == "deg" and span > 90.0:
        cause = (
            f"gaze reaches {span:.0f} deg from the centre: pixels in degree columns? give --units px and "
            "--screen WIDTH_PX HEIGHT_PX WIDTH_CM HEIGHT_CM DISTANCE_CM"
        )
    elif amp > limit or (rec.units == "px" and amp > 0.6 * limit):
        cause = "saccades as large as the screen: wrong screen geometry? check --screen (sizes in cm, distance in cm)"
    elif dur < 8.0 or dur > 400.0:
        cause = f"median duration {dur:.1f} ms: wrong time unit? check --time-unit (ms, us or s)"
    else:
        cause = (
            "wrong screen geometry (distance or size in cm) or a wrong time unit (--time-unit); or a very noisy "
            "recording"
        )
    raise RecordingError(
        f"{rec.path}: {len(bad)} of {len(rows)} saccades are implausible (above "
        f"{MAX_PLAUSIBLE_VELOCITY_DEG_S:.0f} deg/s or larger than {where}; median {amp:.1f} deg at "
        f"{pv:.0f} deg/s); probable cause: {cause}"
    )


def write_rows(rows: list[dict], path) -> None:
    """The main-sequence rows as a CSV (columns ``ROW_FIELDS``), written atomically."""
    from ..folders import write_csv

    write_csv(path, list(ROW_FIELDS), rows)


# ---------------------------------------------------------------------------------------- writing
def write_recording(
    path,
    times_ms,
    x_deg,
    y_deg,
    *,
    fmt: str = "asc",
    rate_hz: float,
    screen: Screen | None = None,
    blinks=(),
    saccades=(),
    units: str = "px",
    seed: int = 0,
    eyes: str = "left",
    right=None,
    coords: str = "gaze",
    remote: bool = False,
    blocks=None,
    whole_ms: bool = False,
) -> Path:
    """Write gaze (degrees, y up; NaN = track loss) as an EyeLink ASC file or a CSV of samples.

    ASC: an ``edf2asc``-like file: header, ``GAZE_COORDS`` (``coords='gaze'``; ``'display'``: only
    ``DISPLAY_COORDS``, as EyeLink I/II; ``'none'``: neither), ``SAMPLES GAZE LEFT [RIGHT] [HTARGET]
    RATE``, samples ``time x y pupil [x y pupil] flags [target fields]`` (``.`` for lost samples),
    ``SBLINK/EBLINK`` for ``blinks`` and ``SSACC/ESACC`` for ``saccades`` ((start, end) ms pairs; a
    dict ``{eye: pairs}`` gives each eye its own). ``eyes``: ``left``, ``right`` or ``both`` (the
    right eye's gaze ``right = (x_deg, y_deg)``, default the left's); ``remote``: remote mode's
    target fields; ``blocks``: (start, end) ms of the START/END blocks (samples outside them are not
    written); ``whole_ms``: time stamps truncated to whole ms (``edf2asc`` without ``-ftime``: written
    twice at 2000 Hz). CSV: columns ``time_ms,x_px,y_px`` (``units='px'``) or ``time_ms,x_deg,y_deg``
    (``units='deg'``), empty cells for lost samples. ``screen`` defaults to 1920 x 1080 px,
    60 x 33.75 cm at 57 cm."""
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
    if eyes not in ("left", "right", "both"):
        raise ValueError(f"eyes must be 'left', 'right' or 'both'; got {eyes!r}")
    which = ("left", "right") if eyes == "both" else (eyes,)
    gaze = {"left": (x, y), "right": (x, y) if right is None else tuple(np.asarray(v, float) for v in right)}
    if eyes == "right" and right is None:
        gaze["right"] = (x, y)
    pix = {e: screen.deg2px(*gaze[e]) for e in which}
    rng = np.random.default_rng(seed)
    integral = whole_ms or np.allclose(t, np.round(t))
    tf = (lambda v: f"{int(math.floor(v + 1e-9))}") if integral else (lambda v: f"{v:.1f}")
    sacc_of = saccades if isinstance(saccades, dict) else {e: saccades for e in which}
    events = []  # (time, order, line)
    for e in which:
        L = e[0].upper()
        px, py = pix[e]
        ex, ey = gaze[e]
        for b0, b1 in blinks:
            events.append((b0, 0, f"SBLINK {L} {tf(b0)}"))
            events.append((b1, 2, f"EBLINK {L} {tf(b0)}\t{tf(b1)}\t{int(round(b1 - b0 + 1000 / rate_hz))}"))
        for s0, s1 in sacc_of.get(e, ()):
            i0, i1 = int(np.searchsorted(t, s0)), min(int(np.searchsorted(t, s1)), len(t) - 1)
            amp = math.hypot(ex[i1] - ex[i0], ey[i1] - ey[i0])
            sp = speed_deg_s(ex[max(i0 - 3, 0) : i1 + 4], ey[max(i0 - 3, 0) : i1 + 4], 1000.0 / rate_hz)
            events.append((s0, 1, f"SSACC {L}  {tf(s0)}"))
            events.append(
                (
                    s1,
                    3,
                    f"ESACC {L}  {tf(s0)}\t{tf(s1)}\t{int(round(s1 - s0 + 1000 / rate_hz))}\t{px[i0]:7.1f}\t"
                    f"{py[i0]:7.1f}\t{px[i1]:7.1f}\t{py[i1]:7.1f}\t{amp:6.2f}\t{np.nanmax(sp):7.0f}",
                )
            )
    events.sort(key=lambda ev: (ev[0], ev[1]))
    w, h = screen._size_px()
    t0 = t[0]
    eye_words = "\t".join(e.upper() for e in which)
    head = [
        f"** CONVERTED FROM {path.with_suffix('.edf').name} using edfapi 4.2.1 Apr  2 2020",
        "** DATE: Wed Mar  8 09:25:20 2023",
        "** TYPE: EDF_FILE BINARY EVENT SAMPLE TAGGED",
        "** VERSION: EYELINK II 1",
        "** SOURCE: EYELINK CL",
        "** EYELINK II CL v6.12 Feb  1 2018 (EyeLink Portable Duo)",
        # the module's name before it moved into oculomotor/, kept: written files stay byte-identical
        "** RECORDED BY conformal-head experiments.eyetracking.write_recording",
        "**",
        "",
    ]
    if coords in ("gaze", "display"):
        head.append(f"MSG\t{tf(t0 - 10)} DISPLAY_COORDS 0 0 {w - 1} {h - 1}")
    head.append(
        f"MSG\t{tf(t0 - 10)} RECCFG CR {int(round(rate_hz))} 2 1 {'LR' if eyes == 'both' else which[0][0].upper()}"
    )
    if coords == "gaze":
        head.append(f"MSG\t{tf(t0 - 10)} GAZE_COORDS 0.00 0.00 {w - 1:.2f} {h - 1:.2f}")
    elif coords != "display" and coords != "none":
        raise ValueError(f"coords must be 'gaze', 'display' or 'none'; got {coords!r}")
    samples_line = (
        f"SAMPLES\tGAZE\t{eye_words}{chr(9) + 'HTARGET' if remote else ''}\tRATE\t{rate_hz:7.2f}"
        "\tTRACKING\tCR\tFILTER\t2"
    )
    spans = [(t[0], t[-1])] if blocks is None else list(blocks)
    pupil = 800.0 + rng.normal(0, 5, len(t))
    out = head
    e_i = 0
    flags = "....." if remote else "..."
    tail = "\t5012\t4988\t612.0\t............." if remote else ""
    for b0, b1 in spans:
        idx = np.flatnonzero((t >= b0) & (t <= b1))
        if not len(idx):
            continue
        out += [
            f"START\t{tf(t[idx[0]])} \t{eye_words}\tSAMPLES\tEVENTS",
            "PRESCALER\t1",
            "VPRESCALER\t1",
            "PUPIL\tAREA",
            samples_line.replace("SAMPLES", "EVENTS", 1),
            samples_line,
        ]
        for i in idx:
            while e_i < len(events) and events[e_i][0] <= t[i] and events[e_i][1] in (0, 1):
                out.append(events[e_i][2])
                e_i += 1
            fields = [tf(t[i])]
            for e in which:
                px, py = pix[e]
                if math.isfinite(px[i]) and math.isfinite(py[i]):
                    fields += [f"{px[i]:7.1f}", f"{py[i]:7.1f}", f"{pupil[i]:7.1f}"]
                else:
                    fields += ["   .", "   .", "    0.0"]
            out.append("\t".join(fields) + "\t" + flags + tail)
            while e_i < len(events) and events[e_i][0] <= t[i]:
                out.append(events[e_i][2])
                e_i += 1
        out.append(f"END\t{tf(t[idx[-1]] + 1)} \tSAMPLES\tEVENTS\tRES\t  38.54\t  31.12")
    path.write_text("\n".join(out) + "\n")
    return path


def synthetic_session(
    generator=None,
    *,
    n_saccades: int = 60,
    rate_hz: float = 500.0,
    noise_deg: float = 0.02,
    n_blinks: int = 3,
    amplitudes=(2.0, 30.0),
    seed: int = 0,
    t0_ms: float = 1_000_000.0,
):
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
    return dict(
        times_ms=t + t0_ms,
        x_deg=x,
        y_deg=y,
        blinks=[(a + t0_ms, b + t0_ms) for a, b in blinks],
        saccades=[(a + t0_ms, b + t0_ms) for a, b in sacc_s],
        amplitudes=np.array([p[1] for p in plan]),
        directions=np.degrees([p[2] for p in plan]),
    )
