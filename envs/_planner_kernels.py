"""Compiled loops (numba) of ``envs.batched_planner``: the burst generator's trajectories and the
eye-position signal of many saccades, element by element with the arithmetic of
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
        plants, start, end, w, t, hv):  # pragma: no cover - compiled
    """SaccadePlan._hv of saccade w at t_rel = t into hv (2 eyes, 2): (h, v) per eye."""
    s_nom = _position(tab, dt, lo[w], hi[w], wt[w], zero[w], prof_settle[w], t, 0)
    if verg_on:
        fast = min(max(t, 0.0), offset[w]) * speedup
        slow = max(t - offset[w], 0.0)
        r = -math.expm1(-(fast + slow) / tau)
    else:
        r = s_nom
    done = t >= plan_settle[w]
    for e in range(2):
        if done:
            hv[e, 0], hv[e, 1] = end[w, e, 0], end[w, e, 1]
            continue
        if plants[w, e] == 0:
            s = s_nom
        else:
            s = _position(tab, dt, lo[w], hi[w], wt[w], zero[w], prof_settle[w], t, plants[w, e])
        hv[e, 0] = start[w, e, 0] + version[w] * s + verg[w, e] * r
        hv[e, 1] = start[w, e, 1] + dv[w, e] * s_nom
    return s_nom


@_jit
def trajectories(tab, dt, lo, hi, wt, zero, prof_settle, plan_settle, offset, tau, speedup, verg_on,
                 version, dv, verg, plants, start, end, step, count, out):  # pragma: no cover - compiled
    """Executed Fick angles (h, v, Listing torsion) per eye, out (n, T, 6), of n saccades at t_rel = k * step
    for k < count[w] (later rows repeat row count[w] - 1).

    Per saccade w: the profile's interpolation in amplitude (lo, hi, wt, zero, prof_settle), the plan's
    settle time and saccade offset, the decomposition (version, dv (2,), verg (2,), plants (2,)) and the
    start and end angles (2, 3); vergence dynamics (tau, speedup) when verg_on.
    """
    n, T = out.shape[0], out.shape[1]
    hv = np.empty((2, 2))
    for w in range(n):
        last = count[w] - 1
        for k in range(T):
            if k > last:
                out[w, k] = out[w, last]
                continue
            _hv(tab, dt, lo, hi, wt, zero, prof_settle, plan_settle, offset, tau, speedup, verg_on, version, dv,
                verg, plants, start, end, w, k * step, hv)
            for e in range(2):
                h, v = hv[e, 0], hv[e, 1]
                out[w, k, 3 * e] = h
                out[w, k, 3 * e + 1] = v
                out[w, k, 3 * e + 2] = 2.0 * math.atan(math.tan(h / 2) * math.tan(v / 2))


@_jit
def signals(tab, dt, lo, hi, wt, zero, prof_settle, plan_settle, offset, tau, speedup, verg_on,
            version, dv, verg, plants, start, end, knot, count, t_rel, sigma, out):  # pragma: no cover - compiled
    """The smoothed, normalised intended trajectory of n saccades (EyePositionSignal.smooth of
    SaccadePlan.eye_position_signal's profile), out (n, m, 4), at t_rel (n, m) (already less the
    delay): the profile normalised per component at count[w] knots every ``knot`` ms, its increments
    spread by the Gaussian's CDF, plus the rest. Arguments as ``trajectories`` (the intended plan)."""
    n, m = t_rel.shape
    r2 = 1.0 / math.sqrt(2.0)
    hv = np.empty((2, 2))
    prev = np.empty(4)
    cur = np.empty(4)
    for w in range(n):
        for j in range(m):
            for c in range(4):
                out[w, j, c] = 0.0
        for k in range(count[w]):
            s_nom = _hv(tab, dt, lo, hi, wt, zero, prof_settle, plan_settle, offset, tau, speedup, verg_on, version,
                        dv, verg, plants, start, end, w, k * knot, hv)
            for e in range(2):
                for c in range(2):
                    total = end[w, e, c] - start[w, e, c]
                    cur[2 * e + c] = (hv[e, c] - start[w, e, c]) / total if total != 0 else s_nom
            if k > 0:
                mid = 0.5 * (k * knot + (k - 1) * knot)
                for j in range(m):
                    g = 0.5 * math.erfc(-((t_rel[w, j] - mid) / sigma) * r2)
                    for c in range(4):
                        out[w, j, c] += g * (cur[c] - prev[c])
            for c in range(4):
                prev[c] = cur[c]
        lk = (count[w] - 1) * knot
        for j in range(m):
            g = 0.5 * math.erfc(-((t_rel[w, j] - lk) / sigma) * r2)
            for c in range(4):
                out[w, j, c] += g * (1.0 - prev[c])
