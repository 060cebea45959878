"""The saccade model's trajectories as compiled loops (numba): the one implementation of the plan's
time course, for one head (``models.SaccadePlan``, N = 1) and for N worlds (``models.SaccadePlans``).

Per saccade ``w`` and time ``t`` after burst onset: the normalised profile of each plant (the burst
generator's table interpolated in amplitude, or the analytic main sequence of the legacy model),
vergence dynamics, the per-eye mix ``start + version s_plant + vergence r`` snapped to the endpoint at
the settle time, Listing torsion, their rates, and the eye-position signal (the intended profile's
increments spread by a Gaussian's CDF). The scalar formulas shared with numpy code (Listing torsion,
the vergence fraction and its rate, the legacy main sequence) are written once, as plain functions
compiled here both inline for the kernels and as elementwise loops over broadcast arrays (cached on
disk like the kernels: ``numba.vectorize``'s ufuncs are built again in every process, ~0.5 s).

No fast-math: results are reproducible to the last bit between calls. Cached on disk as
``conformal.kernels``' kernels are. Saccades run in parallel over numba's threads, one thread per
``SACCADES_PER_THREAD`` saccades at most (:func:`kernel_threads`): one head's plan (the single env,
one Gymnasium env per process) runs on one thread, so that several env processes on as many cores do
not fight over each other's cores (two on two cores kept a fifth of their solo speed with numba's
default of one thread per core in every process); thousands of worlds use every thread.
"""

from __future__ import annotations

import contextlib
import functools
import math
from collections.abc import Iterator

import numba as nb
import numpy as np

from conformal.kernels import DISK_CACHE

__all__ = [
    "SACCADES_PER_THREAD",
    "kernel_threads",
    "limit_plan_threads",
    "angles",
    "command_rows",
    "burst_loop",
    "rates",
    "signals",
    "signal_cdf_table",
    "profile_marks",
    "profile_values",
    "listing_torsion",
    "vergence_fraction",
    "vergence_rate",
    "legacy_position",
    "legacy_rate",
]

_inline = nb.njit(cache=DISK_CACHE, nogil=True, inline="always")
#: Saccades per numba thread of the parallel loops: below 2 x this, one thread (measured in
#: ``benchmarks/env.py``'s contention part and ``benchmarks/planner.py``).
SACCADES_PER_THREAD = 64


_LIMIT = [True]  # limit_plan_threads' setting for this process


def limit_plan_threads(on: bool) -> bool:
    """Whether the saccade model's parallel loops limit numba's threads by their number of saccades
    (:func:`kernel_threads`; on by default). Off, every loop runs on numba's current setting, one thread
    per core by default: for one process alone on a machine, or to measure what the limit buys
    (``benchmarks/env.py``). Returns the previous setting."""
    if not isinstance(on, bool):
        raise TypeError(f"on must be True or False; got {type(on).__name__}")
    prev, _LIMIT[0] = _LIMIT[0], on
    return prev


@contextlib.contextmanager
def kernel_threads(n: int) -> Iterator[int]:
    """numba's threads limited, in this thread, to one per :data:`SACCADES_PER_THREAD` of ``n`` saccades
    (at least 1, at most the current setting) while the block runs; the setting is restored on exit.
    Yields the number in force. With :func:`limit_plan_threads` off, the current setting as it is."""
    prev = nb.get_num_threads()
    k = max(1, min(prev, int(n) // SACCADES_PER_THREAD)) if _LIMIT[0] else prev
    if k == prev:
        yield k
        return
    nb.set_num_threads(k)
    try:
        yield k
    finally:
        nb.set_num_threads(prev)


def _par(f):
    """A parallel loop over the rows of its last argument (``out``), run under :func:`kernel_threads`."""

    @functools.wraps(f)
    def call(*args):
        with kernel_threads(args[-1].shape[0]):
            return call.kernel(*args)

    call.kernel = nb.njit(cache=DISK_CACHE, nogil=True, parallel=True)(f)  # the compiled loop itself
    return call


def _elementwise(loop):
    """``loop`` (``(*inputs, out)``, one float64 result per element of flat inputs), called numpy-style: the
    inputs broadcast and cast to float64, the result shaped as they are (a 0-d input: a numpy float)."""
    kernel = nb.njit(cache=DISK_CACHE, nogil=True, error_model="numpy")(loop)  # x / 0: inf or NaN, as a ufunc

    @functools.wraps(loop)
    def call(*args):
        arrays = np.broadcast_arrays(*(np.asarray(a, np.float64) for a in args))
        out = np.empty(arrays[0].shape)
        kernel(*(np.ascontiguousarray(a).reshape(-1) for a in arrays), out.reshape(-1))
        return out if out.ndim else out[()]

    return call


# ------------------------------------------------------------------------------ scalar formulas
def _listing_torsion(h, v):
    """Fick torsion in Listing's plane: ``tan(t/2) = tan(h/2) tan(v/2)`` (Tweed & Vilis 1990)."""
    return 2.0 * math.atan(math.tan(h / 2) * math.tan(v / 2))


def _vergence_time(t, offset, speedup, tau, latency):
    """The internal time ``s`` of the vergence response ``t`` ms after burst onset: it runs ``speedup``
    times faster from burst onset to the saccade's ``offset`` (saccadic facilitation) and at ``1 / tau``
    after it; without a saccade (``offset <= 0``) it starts ``latency`` ms after onset."""
    if offset <= 0.0:
        t = t - latency
    off = max(offset, 0.0)
    return (min(max(t, 0.0), off) * speedup + max(t - off, 0.0)) / tau


_vtime = _inline(_vergence_time)


def _vergence_fraction(t, offset, speedup, tau, latency):
    """Fraction of a vergence change done ``t`` ms after burst onset (``models.VergenceDynamics``): a
    critically damped response ``1 - (1 + s) e^-s`` (bell-shaped velocity, zero at its start) of the
    internal time ``s`` (:func:`_vergence_time`)."""
    s = _vtime(t, offset, speedup, tau, latency)
    return -math.expm1(-s) - s * math.exp(-s)


_vfrac = _inline(_vergence_fraction)


def _vergence_rate(t, offset, speedup, tau, latency):
    """d(fraction)/dt (1/ms) of :func:`_vergence_fraction` (0 before its start): ``ds/dt s e^-s``."""
    start = latency if offset <= 0.0 else 0.0
    if t - start <= 0:
        return 0.0
    k = (speedup if t - start < offset else 1.0) / tau
    s = _vtime(t, offset, speedup, tau, latency)
    return k * s * math.exp(-s)


def _burst_loop(A, n, dt_ms, every, kb, ka, t2, k2, bm, scale, gain, pos, burst):
    """The burst generator's loop (``models.saccade_generator``) for every amplitude ``A[j]``, step by step:
    motor error -> saturating burst drive minus adaptation -> lagged burst -> omnipause latch at zero
    motor error -> displacement integrator -> each plant's ``T2`` (exact for the integrator's ramp
    over a step: ``E(t) = D(t) - T2 slope + (E0 - D0 + T2 slope) e^{-t/T2}``)."""
    for j in range(A.shape[0]):
        a_j = A[j]
        on = a_j > 0
        D = 0.0
        B = 0.0
        ad = 0.0
        E0 = 0.0
        E1 = 0.0
        E2 = 0.0
        for p in range(3):
            pos[p, 0, j] = 0.0
        burst[0, j] = 0.0
        for i in range(1, n + 1):
            if on:
                drive = max(bm * -math.expm1(-max(a_j - D, 0.0) / scale) - gain * ad, 0.0)
                B = drive + (B - drive) * kb
            else:
                B = 0.0
            ad = B + (ad - B) * ka
            D_new = D + B * dt_ms
            if on and D_new >= a_j:  # omnipause latch: the burst stops when the motor error reaches 0
                D_new = a_j
                B = 0.0
                on = False
            slope = (D_new - D) / dt_ms
            E0 = D_new - t2[0] * slope + (E0 - D + t2[0] * slope) * k2[0]
            E1 = D_new - t2[1] * slope + (E1 - D + t2[1] * slope) * k2[1]
            E2 = D_new - t2[2] * slope + (E2 - D + t2[2] * slope) * k2[2]
            D = D_new
            if i % every == 0:
                k = i // every
                pos[0, k, j] = E0
                pos[1, k, j] = E1
                pos[2, k, j] = E2
                burst[k, j] = B


#: compiled on first use (``models.saccade_generator.simulate``)
burst_loop = nb.njit(cache=DISK_CACHE, nogil=True)(_burst_loop)


def _legacy_position(t, amp, m0, vpk):
    """The main sequence of Van Wetter & Van Opstal (2008) in degrees, ``t`` ms after onset:
    ``E = m0 ln[A e^{vpk t/m0} / (1 + A e^{(vpk t - amp)/m0})]``, ``A = 1 / (1 - e^{-amp/m0})``."""
    if amp <= 0:
        return 0.0
    t = max(t, 0.0)
    lnA = -math.log(-math.expm1(-amp / m0))
    y = lnA + (vpk * t - amp) / m0
    softplus = max(y, 0.0) + math.log1p(math.exp(-abs(y)))  # ln(1 + e^y), stably
    return m0 * (lnA + vpk * t / m0 - softplus)


def _legacy_rate(t, amp, m0, vpk):
    """dE/dt (deg/ms) of :func:`_legacy_position` (0 up to and including onset)."""
    if amp <= 0 or t <= 0:
        return 0.0
    x = (vpk * t - amp) / m0
    return vpk / (1.0 - math.exp(x) / math.expm1(-amp / m0))


_listing = _inline(_listing_torsion)
_vrate = _inline(_vergence_rate)
_lpos = _inline(_legacy_position)
_lrate = _inline(_legacy_rate)


@_elementwise
def listing_torsion(h, v, out):
    """:func:`_listing_torsion` element by element."""
    for i in range(out.size):
        out[i] = _listing(h[i], v[i])


@_elementwise
def vergence_fraction(t, offset, speedup, tau, latency, out):
    """:func:`_vergence_fraction` element by element."""
    for i in range(out.size):
        out[i] = _vfrac(t[i], offset[i], speedup[i], tau[i], latency[i])


@_elementwise
def vergence_rate(t, offset, speedup, tau, latency, out):
    """:func:`_vergence_rate` element by element."""
    for i in range(out.size):
        out[i] = _vrate(t[i], offset[i], speedup[i], tau[i], latency[i])


@_elementwise
def legacy_position(t, amp, m0, vpk, out):
    """:func:`_legacy_position` element by element."""
    for i in range(out.size):
        out[i] = _lpos(t[i], amp[i], m0[i], vpk[i])


@_elementwise
def legacy_rate(t, amp, m0, vpk, out):
    """:func:`_legacy_rate` element by element."""
    for i in range(out.size):
        out[i] = _lrate(t[i], amp[i], m0[i], vpk[i])


# ------------------------------------------------------------------------------ profiles
@_inline
def _interp(tab, dt, prof, w, t, plant):  # pragma: no cover - compiled
    """Row ``plant`` of the table ``tab`` (A, 3, K) at t ms, linear in time, interpolated in amplitude
    between the rows ``prof[w, 0]`` and ``prof[w, 1]`` with weight ``prof[w, 2]``."""
    K = tab.shape[2]
    lo, hi, wt = int(prof[w, 0]), int(prof[w, 1]), prof[w, 2]
    x = min(max(t / dt, 0.0), K - 1.0)
    i = min(int(x), K - 2)
    frac = x - i
    a = (1 - wt) * tab[lo, plant, i] + wt * tab[hi, plant, i]
    b = (1 - wt) * tab[lo, plant, i + 1] + wt * tab[hi, plant, i + 1]
    return a + frac * (b - a)


@_inline
def _position(tab, dt, prof, w, t, plant, legacy, m0, vpk):  # pragma: no cover - compiled
    """Normalised position of ``plant`` of saccade w at t ms after burst onset. ``prof[w]``: (lo, hi,
    weight) of its interpolation in amplitude, its amplitude (deg) and its profile's settle time."""
    amp, settle = prof[w, 3], prof[w, 4]
    if amp <= 0:
        return 1.0 if t >= 0 else 0.0
    if t <= 0:
        return 0.0
    if legacy:
        return 1.0 if t >= settle else _lpos(t, amp, m0, vpk) / amp
    if t >= settle or t >= (tab.shape[2] - 1) * dt:
        return 1.0
    return _interp(tab, dt, prof, w, t, plant)


@_inline
def _rate(rtab, dt, prof, w, t, plant, legacy, m0, vpk):  # pragma: no cover - compiled
    """d(position)/dt (1/ms) of :func:`_position` (0 outside the movement); ``rtab``: the table's rates."""
    amp, settle = prof[w, 3], prof[w, 4]
    if amp <= 0 or t <= 0 or t >= settle:
        return 0.0
    if legacy:
        return _lrate(t, amp, m0, vpk) / amp
    if t >= (rtab.shape[2] - 1) * dt:
        return 0.0
    return _interp(rtab, dt, prof, w, t, plant)


@_par
def profile_values(tab, rtab, dt, prof, legacy, m0, vpk, plant, t_rel, rate, out):  # pragma: no cover - compiled
    """Normalised positions (or, with ``rate``, their rates in 1/ms) of ``plant`` of n profiles, out (n, T),
    at ``t_rel`` (n, T) ms after burst onset."""
    n, T = t_rel.shape
    for w in nb.prange(n):
        for k in range(T):
            if rate:
                out[w, k] = _rate(rtab, dt, prof, w, t_rel[w, k], plant, legacy, m0, vpk)
            else:
                out[w, k] = _position(tab, dt, prof, w, t_rel[w, k], plant, legacy, m0, vpk)


# ------------------------------------------------------------------------------ plans
@_inline
def _hv(tab, dt, prof, legacy, m0, vpk, plan, verg_on, speedup, latency, plants, start, end, w, t):  # pragma: no cover
    """Fick (h, v) of both eyes of saccade w at t ms after onset: (s_nom, h_left, v_left, h_right, v_right).
    ``plan[w]``: (settle time, saccade offset, version, dv_left, dv_right, vergence_left, vergence_right,
    vergence time scale ``tau``: ``models.VergenceDynamics``' for this plan's convergence or divergence)."""
    s_nom = _position(tab, dt, prof, w, t, 0, legacy, m0, vpk)
    if t >= plan[w, 0]:
        return s_nom, end[w, 0, 0], end[w, 0, 1], end[w, 1, 0], end[w, 1, 1]
    r = _vfrac(t, plan[w, 1], speedup, plan[w, 7], latency) if verg_on else s_nom
    s0 = s_nom if plants[w, 0] == 0 else _position(tab, dt, prof, w, t, plants[w, 0], legacy, m0, vpk)
    s1 = s_nom if plants[w, 1] == 0 else _position(tab, dt, prof, w, t, plants[w, 1], legacy, m0, vpk)
    version = plan[w, 2]
    return (
        s_nom,
        start[w, 0, 0] + version * s0 + plan[w, 5] * r,
        start[w, 0, 1] + plan[w, 3] * s_nom,
        start[w, 1, 0] + version * s1 + plan[w, 6] * r,
        start[w, 1, 1] + plan[w, 4] * s_nom,
    )


@_par
def angles(
    tab, dt, prof, legacy, m0, vpk, plan, verg_on, speedup, latency, plants, start, end, t_rel, out
):  # pragma: no cover - compiled
    """Fick angles (h, v, Listing torsion) of both eyes, out (n, T, 2, 3), of n saccades at ``t_rel``
    (n, T) ms after their onsets. Arguments: see :func:`_hv` (``end``: executed or intended endpoint)."""
    n, T = t_rel.shape
    for w in nb.prange(n):
        for k in range(T):
            if k > 0 and t_rel[w, k] == t_rel[w, k - 1]:  # a held row (command tables): the same angles
                for e in range(2):
                    for c in range(3):
                        out[w, k, e, c] = out[w, k - 1, e, c]
                continue
            _, h0, v0, h1, v1 = _hv(
                tab, dt, prof, legacy, m0, vpk, plan, verg_on, speedup, latency, plants, start, end, w, t_rel[w, k]
            )
            out[w, k, 0, 0], out[w, k, 0, 1], out[w, k, 0, 2] = h0, v0, _listing(h0, v0)
            out[w, k, 1, 0], out[w, k, 1, 1], out[w, k, 1, 2] = h1, v1, _listing(h1, v1)


@_par
def command_rows(
    tab, dt, prof, legacy, m0, vpk, plan, verg_on, speedup, latency, plants, start, end, count, dest, out
):  # pragma: no cover - compiled
    """:func:`angles` of saccade w at ``t_rel[w, k] = min(k, count[w] - 1)`` (a command table: every whole
    ms from onset, then held), written to ``out[dest[w]]`` (out: (N, T, 2, 3), dest: (n,) distinct rows):
    each row in use computed once, the held rows copies of the last one, as :func:`angles` copies a row
    whose time repeats the previous row's (bit-identical to it, without the (n, T) array of times)."""
    n, T = dest.shape[0], out.shape[1]
    for w in nb.prange(n):
        o = out[dest[w]]
        rows = min(count[w], T)
        # tan(v / 2) of Listing's torsion, kept while an eye's vertical angle repeats (the vergence tail)
        va = vb = math.nan
        ta = tb = 0.0
        for k in range(rows):
            _, h0, v0, h1, v1 = _hv(
                tab, dt, prof, legacy, m0, vpk, plan, verg_on, speedup, latency, plants, start, end, w, float(k)
            )
            if v0 != va or math.copysign(1.0, v0) != math.copysign(1.0, va):  # (-0.0 == 0.0: the sign too)
                va, ta = v0, math.tan(v0 / 2)
            if v1 != vb or math.copysign(1.0, v1) != math.copysign(1.0, vb):
                vb, tb = v1, math.tan(v1 / 2)
            o[k, 0, 0], o[k, 0, 1], o[k, 0, 2] = h0, v0, 2.0 * math.atan(math.tan(h0 / 2) * ta)
            o[k, 1, 0], o[k, 1, 1], o[k, 1, 2] = h1, v1, 2.0 * math.atan(math.tan(h1 / 2) * tb)
        last = rows - 1
        for k in range(rows, T):
            for e in range(2):
                for c in range(3):
                    o[k, e, c] = o[last, e, c]


@_par
def rates(
    tab, rtab, dt, prof, legacy, m0, vpk, plan, verg_on, speedup, latency, plants, start, end, t_rel, out
):  # pragma: no cover - compiled
    """Rates (rad/ms) of the Fick angles of both eyes, out (n, T, 2, 3), at ``t_rel`` (n, T); torsion's
    by the chain rule of Listing's ``tan(t/2) = tan(h/2) tan(v/2)``."""
    n, T = t_rel.shape
    for w in nb.prange(n):
        for k in range(T):
            t = t_rel[w, k]
            _, h0, v0, h1, v1 = _hv(
                tab, dt, prof, legacy, m0, vpk, plan, verg_on, speedup, latency, plants, start, end, w, t
            )
            if t >= plan[w, 0]:
                for e in range(2):
                    for c in range(3):
                        out[w, k, e, c] = 0.0
                continue
            ds = _rate(rtab, dt, prof, w, t, 0, legacy, m0, vpk)
            dr = _vrate(t, plan[w, 1], speedup, plan[w, 7], latency) if verg_on else ds
            for e in range(2):
                dsp = ds if plants[w, e] == 0 else _rate(rtab, dt, prof, w, t, plants[w, e], legacy, m0, vpk)
                dh = plan[w, 2] * dsp + plan[w, 5 + e] * dr
                dv = plan[w, 3 + e] * ds
                h, v = (h0, v0) if e == 0 else (h1, v1)
                th, tv = math.tan(h / 2), math.tan(v / 2)
                out[w, k, e, 0], out[w, k, e, 1] = dh, dv
                out[w, k, e, 2] = (1.0 / (1.0 + (th * tv) ** 2)) * ((1 + th**2) * tv * dh + th * (1 + tv**2) * dv)


@_inline
def _norm(x, s, e, s_nom):  # pragma: no cover - compiled
    total = e - s
    return (x - s) / total if total != 0 else s_nom


@_inline
def _cdf(d, sigma):  # pragma: no cover - compiled
    """The Gaussian's CDF (s.d. ``sigma``) at ``d``: the weight of an increment ``d`` ms before now."""
    return 0.5 * math.erfc(-(d / sigma) * (1.0 / math.sqrt(2.0)))


@nb.njit(cache=DISK_CACHE, nogil=True)
def signal_cdf_table(lo, step, sigma, out):  # pragma: no cover - compiled
    """``out[i]`` = the Gaussian's CDF at ``lo + i step`` (what :func:`signals` reads for the time
    differences on that grid: the same function of the same numbers, so the same bits)."""
    for i in range(out.shape[0]):
        out[i] = _cdf(lo + i * step, sigma)


@_inline
def _weight(d, sigma, cdf, lo, step):  # pragma: no cover - compiled
    """:func:`_cdf` of ``d``, read from ``cdf`` (:func:`signal_cdf_table` from ``lo`` by ``step``) where
    ``d`` is exactly one of its grid's numbers, else computed."""
    x = (d - lo) / step
    if x >= 0.0 and x < cdf.shape[0]:
        i = int(x)
        if lo + i * step == d:
            return cdf[i]
    return _cdf(d, sigma)


@_par
def signals(
    tab,
    dt,
    prof,
    legacy,
    m0,
    vpk,
    plan,
    verg_on,
    speedup,
    latency,
    plants,
    start,
    end,
    knot,
    count,
    t_rel,
    sigma,
    cdf,
    cdf_lo,
    out,
):  # pragma: no cover - compiled
    """The eye-position signal's normalised time course (``models.EyePositionSignal``), out (n, m, 4)
    [(h, v) of the left eye, then the right], at ``t_rel`` (n, m) (already less the delay): the intended
    profile normalised per component at count[w] knots every ``knot`` ms, its increments spread by the
    Gaussian's CDF (s.d. ``sigma``), plus the rest. ``cdf``: the CDF on the grid ``cdf_lo + i knot / 2``
    (:func:`signal_cdf_table`; the time differences of times on that grid from the knots' midpoints), or
    empty: computed at every knot."""
    n, m = t_rel.shape
    step = 0.5 * knot
    for w in nb.prange(n):
        for j in range(m):
            for c in range(4):
                out[w, j, c] = 0.0
        p0 = p1 = p2 = p3 = 0.0
        for k in range(count[w]):
            s_nom, h0, v0, h1, v1 = _hv(
                tab, dt, prof, legacy, m0, vpk, plan, verg_on, speedup, latency, plants, start, end, w, k * knot
            )
            c0 = _norm(h0, start[w, 0, 0], end[w, 0, 0], s_nom)
            c1 = _norm(v0, start[w, 0, 1], end[w, 0, 1], s_nom)
            c2 = _norm(h1, start[w, 1, 0], end[w, 1, 0], s_nom)
            c3 = _norm(v1, start[w, 1, 1], end[w, 1, 1], s_nom)
            if k > 0:
                mid = 0.5 * (k * knot + (k - 1) * knot)
                for j in range(m):
                    g = _weight(t_rel[w, j] - mid, sigma, cdf, cdf_lo, step)
                    out[w, j, 0] += g * (c0 - p0)
                    out[w, j, 1] += g * (c1 - p1)
                    out[w, j, 2] += g * (c2 - p2)
                    out[w, j, 3] += g * (c3 - p3)
            p0, p1, p2, p3 = c0, c1, c2, c3
        lk = (count[w] - 1) * knot
        for j in range(m):
            g = _weight(t_rel[w, j] - lk, sigma, cdf, cdf_lo, step)
            out[w, j, 0] += g * (1.0 - p0)
            out[w, j, 1] += g * (1.0 - p1)
            out[w, j, 2] += g * (1.0 - p2)
            out[w, j, 3] += g * (1.0 - p3)


@_par
def profile_marks(tab, dt, lo, hi, wt, amp, bound, threshold, settle_deg, out):  # pragma: no cover - compiled
    """The burst generator's detected onset and offset (first and last step whose nominal speed exceeds
    ``threshold`` deg/s, np.gradient's differences), settle time (after the last step at which a plant
    is ``settle_deg`` or more from the endpoint) and peak speed, out (n, 4), of each interpolated
    profile over its first bound[w] steps (past which nothing can change them)."""
    n, K = out.shape[0], tab.shape[2]
    for w in nb.prange(n):
        Kb, a, l, h, f = bound[w], amp[w], lo[w], hi[w], wt[w]
        first = last = late = -1
        peak = -math.inf
        for k in range(Kb):
            # np.gradient of the whole row: central differences but at the table's two ends
            k0, k1 = max(k - 1, 0), min(k + 1, K - 1)
            p0 = (1 - f) * tab[l, 0, k0] + f * tab[h, 0, k0]
            p1 = (1 - f) * tab[l, 0, k1] + f * tab[h, 0, k1]
            rate = (p1 - p0) / (2.0 * dt) if 0 < k < K - 1 else (p1 - p0) / dt
            if rate * a * 1000.0 > threshold:
                if first < 0:
                    first = k
                last = k
            peak = max(peak, rate)
            err = -math.inf
            for pl in range(3):
                err = max(err, 1.0 - ((1 - f) * tab[l, pl, k] + f * tab[h, pl, k]))
            if err * a >= settle_deg:
                late = k
        out[w, 0] = first * dt if first >= 0 else 0.0
        out[w, 1] = (last + 1) * dt if first >= 0 else 0.0
        out[w, 2] = (late + 1) * dt if late >= 0 else 0.0
        out[w, 3] = peak * a * 1000.0
