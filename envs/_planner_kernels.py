"""Compiled loops (numba) of ``envs.batched_planner``: the burst generator's trajectories and the
eye-position signal of many saccades (in parallel over saccades), element by element with the arithmetic of
``models.SaccadeProfile.position``, ``models.SaccadePlan._hv`` / ``eye_position_signal`` and
``models.EyePositionSignal.smooth`` (no fast-math: the tests compare them with those to 1e-9).
Cached on disk as ``conformal.kernels``' kernels are."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from conformal.kernels import DISK_CACHE

__all__ = ["trajectories", "signals"]

_jit = nb.njit(cache=DISK_CACHE, nogil=True)
_inline = nb.njit(cache=DISK_CACHE, nogil=True, inline="always")
#: the batch kernels: one saccade per iteration, spread over numba's threads (``numba.set_num_threads``
#: bounds them; by default as many as the machine's cores)
_par = nb.njit(cache=DISK_CACHE, nogil=True, parallel=True)


@_inline
def _position(tab, dt, lo, hi, wt, zero, prof_settle, t, plant):  # pragma: no cover - compiled
    """SaccadeProfile.position of one saccade at one time (lo/hi/wt: its interpolation in amplitude)."""
    K = tab.shape[2]
    if zero:
        return 1.0 if t >= 0 else 0.0
    if t <= 0:
        return 0.0
    if t >= prof_settle or t >= (K - 1) * dt:
        return 1.0
    x = min(max(t / dt, 0.0), K - 1.0)
    i = min(int(x), K - 2)
    frac = x - i
    a = (1 - wt) * tab[lo, plant, i] + wt * tab[hi, plant, i]
    b = (1 - wt) * tab[lo, plant, i + 1] + wt * tab[hi, plant, i + 1]
    return a + frac * (b - a)


@_inline
def _hv(tab, dt, lo, hi, wt, zero, prof_settle, plan_settle, offset, tau, speedup, verg_on, version, dv, verg,
        plants, start, end, w, t):  # pragma: no cover - compiled
    """SaccadePlan._hv of saccade w at t_rel = t: (s_nom, h_left, v_left, h_right, v_right)."""
    s_nom = _position(tab, dt, lo[w], hi[w], wt[w], zero[w], prof_settle[w], t, 0)
    if t >= plan_settle[w]:
        return s_nom, end[w, 0, 0], end[w, 0, 1], end[w, 1, 0], end[w, 1, 1]
    if verg_on:
        fast = min(max(t, 0.0), offset[w]) * speedup
        slow = max(t - offset[w], 0.0)
        r = -math.expm1(-(fast + slow) / tau)
    else:
        r = s_nom
    s0 = s_nom if plants[w, 0] == 0 else _position(tab, dt, lo[w], hi[w], wt[w], zero[w], prof_settle[w], t, plants[w, 0])
    s1 = s_nom if plants[w, 1] == 0 else _position(tab, dt, lo[w], hi[w], wt[w], zero[w], prof_settle[w], t, plants[w, 1])
    return (s_nom, start[w, 0, 0] + version[w] * s0 + verg[w, 0] * r, start[w, 0, 1] + dv[w, 0] * s_nom,
            start[w, 1, 0] + version[w] * s1 + verg[w, 1] * r, start[w, 1, 1] + dv[w, 1] * s_nom)


@_inline
def _listing(h, v):  # pragma: no cover - compiled
    return 2.0 * math.atan(math.tan(h / 2) * math.tan(v / 2))


@_par
def trajectories(tab, dt, lo, hi, wt, zero, prof_settle, plan_settle, offset, tau, speedup, verg_on,
                 version, dv, verg, plants, start, end, step, count, out):  # pragma: no cover - compiled
    """Executed Fick angles (h, v, Listing torsion) per eye, out (n, T, 6), of n saccades at t_rel = k * step
    for k < count[w] (later rows repeat row count[w] - 1).

    Per saccade w: the profile's interpolation in amplitude (lo, hi, wt, zero, prof_settle), the plan's
    settle time and saccade offset, the decomposition (version, dv (2,), verg (2,), plants (2,)) and the
    start and end angles (2, 3); vergence dynamics (tau, speedup) when verg_on. Saccades in parallel.
    """
    n, T = out.shape[0], out.shape[1]
    for w in nb.prange(n):
        last = count[w] - 1
        for k in range(T):
            if k > last:
                for c in range(6):
                    out[w, k, c] = out[w, last, c]
                continue
            _, h0, v0, h1, v1 = _hv(tab, dt, lo, hi, wt, zero, prof_settle, plan_settle, offset, tau, speedup,
                                    verg_on, version, dv, verg, plants, start, end, w, k * step)
            out[w, k, 0], out[w, k, 1], out[w, k, 2] = h0, v0, _listing(h0, v0)
            out[w, k, 3], out[w, k, 4], out[w, k, 5] = h1, v1, _listing(h1, v1)


@_inline
def _norm(x, s, e, s_nom):  # pragma: no cover - compiled
    total = e - s
    return (x - s) / total if total != 0 else s_nom


@_par
def signals(tab, dt, lo, hi, wt, zero, prof_settle, plan_settle, offset, tau, speedup, verg_on,
            version, dv, verg, plants, start, end, knot, count, t_rel, sigma, out):  # pragma: no cover - compiled
    """The smoothed, normalised intended trajectory of n saccades (EyePositionSignal.smooth of
    SaccadePlan.eye_position_signal's profile), out (n, m, 4), at t_rel (n, m) (already less the
    delay): the profile normalised per component at count[w] knots every ``knot`` ms, its increments
    spread by the Gaussian's CDF, plus the rest. Arguments as ``trajectories`` (the intended plan)."""
    n, m = t_rel.shape
    r2 = 1.0 / math.sqrt(2.0)
    for w in nb.prange(n):
        for j in range(m):
            for c in range(4):
                out[w, j, c] = 0.0
        p0 = p1 = p2 = p3 = 0.0
        for k in range(count[w]):
            s_nom, h0, v0, h1, v1 = _hv(tab, dt, lo, hi, wt, zero, prof_settle, plan_settle, offset, tau, speedup,
                                        verg_on, version, dv, verg, plants, start, end, w, k * knot)
            c0 = _norm(h0, start[w, 0, 0], end[w, 0, 0], s_nom)
            c1 = _norm(v0, start[w, 0, 1], end[w, 0, 1], s_nom)
            c2 = _norm(h1, start[w, 1, 0], end[w, 1, 0], s_nom)
            c3 = _norm(v1, start[w, 1, 1], end[w, 1, 1], s_nom)
            if k > 0:
                mid = 0.5 * (k * knot + (k - 1) * knot)
                for j in range(m):
                    g = 0.5 * math.erfc(-((t_rel[w, j] - mid) / sigma) * r2)
                    out[w, j, 0] += g * (c0 - p0)
                    out[w, j, 1] += g * (c1 - p1)
                    out[w, j, 2] += g * (c2 - p2)
                    out[w, j, 3] += g * (c3 - p3)
            p0, p1, p2, p3 = c0, c1, c2, c3
        lk = (count[w] - 1) * knot
        for j in range(m):
            g = 0.5 * math.erfc(-((t_rel[w, j] - lk) / sigma) * r2)
            out[w, j, 0] += g * (1.0 - p0)
            out[w, j, 1] += g * (1.0 - p1)
            out[w, j, 2] += g * (1.0 - p2)
            out[w, j, 3] += g * (1.0 - p3)


@_par
def profile_marks(tab, dt, lo, hi, wt, amp, bound, threshold, settle_deg, out):  # pragma: no cover - compiled
    """SaccadeProfile's detected onset and offset (first and last step whose nominal speed exceeds
    ``threshold`` deg/s, np.gradient's differences), settle time (after the last step at which a plant
    is ``settle_deg`` or more from the endpoint) and peak speed, out (n, 4), of each interpolated
    profile over its first bound[w] steps (past which nothing can change them: ``_burst_table``)."""
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
