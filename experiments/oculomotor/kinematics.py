"""One way to measure a saccade: eye velocity, the 30 deg/s crossings, peak velocity, detection.

Velocity is the first derivative of a Savitzky--Golay filter (Savitzky & Golay 1964, Anal Chem
36:1627), as Nyström & Holmqvist (2010, Behav Res Methods 42:188) use for saccade detection: a
quadratic fitted by least squares over a window of ``2m + 1`` samples, whose derivative at the
centre is ``sum_k k x[n+k] / (dt sum_k k^2)``. The window spans ``SG_SPAN_MS`` = 4 ms
(``m = max(1, round(2 ms / dt))``: 3 samples at 250 and 500 Hz, 5 at 1000 Hz, 9 at 2000 Hz), so the
estimator is nearly the same filter at every rate; Nyström & Holmqvist's 20 ms window is meant for
detection and lowers the peak of a 10 deg saccade by a third. The bias of the peak velocity against
the true peak, measured on simulated saccades (``tests/test_oculomotor_kinematics.py``; the numbers are
in the README, "Your eye-tracker's files"), is what the generator fit's forward model reproduces,
because the fit measures the model's traces with these same functions.

No velocity spans missing data: a derivative is computed only where all ``2m + 1`` samples are
present (not NaN) and consecutive (each step one sampling period, +-25 %, inside one recording
block). Elsewhere it is NaN, and a threshold crossing that meets a NaN is no crossing: the saccade
is not measured.

Detection: Engbert & Kliegl (2003, Vision Res 43:1035, eqs. 1-3), the velocity threshold an
ellipse of ``ENGBERT_LAMBDA`` = 6 median-based SDs per axis, ``sigma^2 = median(v^2) - median(v)^2``,
over at least ``MIN_SACCADE_MS`` = 6 ms (3 samples at 500 Hz, their minimum); a threshold below
``ENGBERT_FLOOR_DEG_S`` (noise-free traces) is raised to it.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "THRESHOLD_DEG_S",
    "SG_SPAN_MS",
    "sg_half_window",
    "steps_ok",
    "velocity",
    "speed_deg_s",
    "crossing",
    "measure_saccade",
    "measure_saccades",
    "engbert_kliegl",
    "SKEWNESS_MIN_RATE_HZ",
]

THRESHOLD_DEG_S = 30.0  #: = models.saccade_generator.DETECTION_THRESHOLD_DEG_S (not imported: no MuJoCo here)
SG_SPAN_MS = 4.0
SKEWNESS_MIN_RATE_HZ = 250.0
ENGBERT_LAMBDA = 6.0
ENGBERT_FLOOR_DEG_S = 5.0
MIN_SACCADE_MS = 6.0
_STEP_TOL = 0.25


def sg_half_window(dt_ms: float) -> int:
    """``m`` of the Savitzky--Golay window ``2m + 1`` at a sampling period ``dt_ms``."""
    return max(1, int(round(SG_SPAN_MS / 2.0 / dt_ms)))


def steps_ok(times_ms: np.ndarray, dt_ms: float, block: np.ndarray | None = None) -> np.ndarray:
    """(n - 1,) True where the step from sample i to i + 1 is one sampling period (+-25 %) inside one
    block: the steps a derivative may span."""
    ok = np.abs(np.diff(np.asarray(times_ms, float)) - dt_ms) <= _STEP_TOL * dt_ms
    if block is not None:
        ok &= np.asarray(block)[1:] == np.asarray(block)[:-1]
    return ok


def _window_all(flags: np.ndarray, lo: int, hi: int, n: int) -> np.ndarray:
    """out[i] = all(flags[i + lo : i + hi]) for i in [0, n) (False where the window leaves ``flags``);
    along the first axis of (len, c) flags, column by column."""
    c = np.concatenate([np.zeros((1, *flags.shape[1:]), np.int64), np.cumsum(~flags, axis=0)])
    i = np.arange(n)
    a, b = i + lo, i + hi
    inside = (a >= 0) & (b <= len(flags))
    out = np.zeros((n, *flags.shape[1:]), bool)
    out[inside] = (c[b[inside]] - c[a[inside]]) == 0
    return out


def velocity(a: np.ndarray, dt_ms: float, ok_steps: np.ndarray | None = None) -> np.ndarray:
    """Savitzky--Golay first derivative (units of ``a`` per second; module docstring); NaN where the
    window holds a NaN, leaves the trace or spans a step that ``ok_steps`` marks False. ``a`` is one
    trace (n,) or several sampled together, one per column (n, c)."""
    a = np.asarray(a, float)
    n = len(a)
    m = sg_half_window(dt_ms)
    k = np.arange(-m, m + 1)
    w = k / float((k * k).sum()) / (dt_ms / 1000.0)
    v = np.full(a.shape, np.nan)
    if n < 2 * m + 1:
        return v
    z = np.nan_to_num(a)
    if a.ndim == 1:
        v[m : n - m] = np.correlate(z, w, mode="valid")
    else:  # the same 1-D product per column (bit-identical to one trace at a time)
        for j in range(a.shape[1]):
            v[m : n - m, j] = np.correlate(np.ascontiguousarray(z[:, j]), w, mode="valid")
    good = _window_all(np.isfinite(a), -m, m + 1, n)
    if ok_steps is not None:
        steps = _window_all(np.asarray(ok_steps, bool), -m, m, n)
        good &= steps if a.ndim == 1 else steps[:, None]
    v[~good] = np.nan
    return v


def speed_deg_s(x: np.ndarray, y: np.ndarray | None, dt_ms: float, ok_steps: np.ndarray | None = None) -> np.ndarray:
    """Eye speed (deg/s): the norm of the two velocity components (``y`` None: a one-dimensional trace)."""
    vx = velocity(x, dt_ms, ok_steps)
    return np.abs(vx) if y is None else np.hypot(vx, velocity(y, dt_ms, ok_steps))


def _threshold_time(t_in, t_out, s_in, s_out):
    """The time where the speed crosses ``THRESHOLD_DEG_S`` between a sample above it (``t_in``, ``s_in``)
    and the next one below (``t_out``, ``s_out``), linearly interpolated (scalars or arrays)."""
    return t_in + (t_out - t_in) * (s_in - THRESHOLD_DEG_S) / (s_in - s_out)


def _parabola_shift(a, b, c, dt):
    """The vertex of the parabola through three equally spaced speeds ``a, b, c`` (b the peak) as an
    offset from b's time (``dt`` the spacing); meaningful where ``a - 2 b + c < 0``."""
    return 0.5 * (a - c) / (a - 2 * b + c) * dt


def _skewness(tp, on, off, rate_hz: float):
    """The peak's place in the saccade, (peak time - onset) / duration; NaN below ``SKEWNESS_MIN_RATE_HZ``."""
    if rate_hz < SKEWNESS_MIN_RATE_HZ:
        return np.full(np.shape(on), math.nan) if np.ndim(on) else math.nan
    return (tp - on) / (off - on)


def crossing(t, s, i, step) -> float | None:
    """Walk from the peak index ``i`` by ``step`` to the first sample below threshold; the crossing
    time interpolated linearly; None if the walk leaves the data or meets a NaN (missing data)."""
    n = len(s)
    j = i
    while 0 <= j + step < n:
        k = j + step
        if not np.isfinite(s[k]):
            return None
        if s[k] < THRESHOLD_DEG_S:
            return float(_threshold_time(t[j], t[k], s[j], s[k]))
        j = k
    return None


def measure_saccade(
    t: np.ndarray, s: np.ndarray, i_peak: int, rate_hz: float
) -> tuple[float, float, float, float, float] | None:
    """Onset and offset (30 deg/s crossings), peak velocity, peak time and skewness of the saccade
    whose speed trace ``s`` (at times ``t``) peaks at sample ``i_peak``; None where a crossing is
    missing. The peak time is refined by a parabola through the top three samples."""
    on = crossing(t, s, i_peak, -1)
    off = crossing(t, s, i_peak, +1)
    if on is None or off is None or off <= on:
        return None
    pk = float(s[i_peak])
    tp = float(t[i_peak])
    if 0 < i_peak < len(s) - 1 and np.all(np.isfinite(s[i_peak - 1 : i_peak + 2])):
        a, b, c = s[i_peak - 1], s[i_peak], s[i_peak + 1]
        if a - 2 * b + c < 0:
            tp += _parabola_shift(a, b, c, t[i_peak + 1] - t[i_peak])
    return on, off, pk, tp, _skewness(tp, on, off, rate_hz)


def measure_saccades(t: np.ndarray, s: np.ndarray, rate_hz: float) -> np.ndarray:
    """:func:`measure_saccade` of each column of the speed traces ``s`` (n, c), sampled together at
    times ``t`` (n,), at that column's peak (``nanargmax``), all at once: (5, c) rows onset, offset,
    peak velocity, peak time, skewness, NaN where :func:`measure_saccade` gives None. The same
    arithmetic, so the same numbers to the bit (``tests/test_oculomotor_kinematics.py``)."""
    t = np.asarray(t, float)
    s = np.asarray(s, float)
    n, c = s.shape
    cols = np.arange(c)
    ip = np.nanargmax(s, axis=0)
    rows = np.arange(n)[:, None]
    with np.errstate(invalid="ignore"):
        stop = ~np.isfinite(s) | (s < THRESHOLD_DEG_S)  # where a walk from the peak ends
    # the first stop on each side of the peak: a NaN there is no crossing, a sample below threshold is one
    k_on = np.where(stop & (rows < ip), rows, -1).max(axis=0)
    k_off = np.where(stop & (rows > ip), rows, n).min(axis=0)
    out = np.full((5, c), np.nan)
    ok = (k_on >= 0) & (k_off < n)
    ok[ok] &= np.isfinite(s[k_on[ok], cols[ok]]) & np.isfinite(s[k_off[ok], cols[ok]])
    if not ok.any():
        return out
    c_ok = cols[ok]
    ko, kf, i = k_on[ok], k_off[ok], ip[ok]
    jo, jf = ko + 1, kf - 1
    so, sf = s[jo, c_ok], s[jf, c_ok]
    on = _threshold_time(t[jo], t[ko], so, s[ko, c_ok])
    off = _threshold_time(t[jf], t[kf], sf, s[kf, c_ok])
    pk = s[i, c_ok]
    tp = t[i].copy()
    inner = (i > 0) & (i < n - 1)
    lo_, hi_ = np.clip(i - 1, 0, n - 1), np.clip(i + 1, 0, n - 1)
    a, b, cc = s[lo_, c_ok], s[i, c_ok], s[hi_, c_ok]
    fin = inner & np.isfinite(a) & np.isfinite(b) & np.isfinite(cc)
    with np.errstate(invalid="ignore", divide="ignore"):
        shift = _parabola_shift(a, b, cc, t[hi_] - t[i])
    bend = fin & (a - 2 * b + cc < 0)
    tp[bend] += shift[bend]
    good = off > on
    skew = _skewness(tp, on, np.where(good, off, on + 1.0), rate_hz)
    keep = c_ok[good]
    out[:, keep] = np.stack([on, off, pk, tp, skew])[:, good]
    return out


def engbert_kliegl(times_ms, x, y, dt_ms: float, ok_steps=None) -> list[tuple[float, float]]:
    """Engbert & Kliegl (2003) saccades as (onset, offset) ms (module docstring); never across a gap."""
    vx, vy = velocity(x, dt_ms, ok_steps), velocity(y, dt_ms, ok_steps)
    fin = np.isfinite(vx) & np.isfinite(vy)
    if fin.sum() < 10:
        return []

    def eta(v):
        sd = math.sqrt(max(float(np.median(v[fin] ** 2) - np.median(v[fin]) ** 2), 0.0))
        return max(ENGBERT_LAMBDA * sd, ENGBERT_FLOOR_DEG_S)

    ex, ey = eta(vx), eta(vy)
    with np.errstate(invalid="ignore"):
        above = fin & ((vx / ex) ** 2 + (vy / ey) ** 2 > 1.0)
    m = np.concatenate([[0], above.astype(np.int8), [0]])
    d = np.diff(m)
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1
    need = max(2, int(math.ceil(MIN_SACCADE_MS / dt_ms - 1e-9)))
    t = np.asarray(times_ms, float)
    return [(float(t[a]), float(t[b])) for a, b in zip(starts, ends) if b - a + 1 >= need]
