"""The brain's side of N worlds at once: saccade plans, command tables and eye-position signals as arrays.

``envs.BatchedBinocularSaccade`` plans one saccade per world per step. Building a
``models.SaccadePlan`` object per world costs about a millisecond of Python, which alone would cap
4096 worlds near 1,000 env-steps/s; this module computes the same quantities for all worlds with
numpy arrays:

* the plan of ``models.Head.plan_saccade`` (and ``plan_saccade_to`` for vergence actions): the
  retinotopic displacement at the current fixation distance, the fixation angles of both eyes
  (Listing torsion), the amplitude, endpoint noise drawn from each world's own generator;
* the trajectory of ``models.SaccadePlan``: the burst generator's tabulated profile interpolated
  in amplitude (``models.BurstGenerator.profile``: its detected onset/offset, settle time and
  peak speed included) or the legacy main sequence, abducting/adducting plants, vergence dynamics
  (``models.VergenceDynamics``), snapped to the endpoint at the settle time;
* the efference copies and the executed rotation;
* the eye-position signal (``SaccadePlan.eye_position_signal``: the intended profile's increments
  spread by the Gaussian's CDF), kept per world between steps.

Every expression follows the one it batches, in the same order, so the arrays agree with the
per-world objects to rounding (``tests/test_batched_planner.py``: < 1e-9 rad and exact integer
times, against ``models.Head`` and ``models.SaccadePlan``). Saccades that would leave the
oculomotor range are shortened by ``envs.saccade_env.plan_clipped``'s bisection, all such worlds at
once. Vergence actions combined with endpoint noise are planned with the single env's code on the
one host ``models.Head``, brought to each such world's state; their plans then join the arrays.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, fields

import numpy as np
from scipy.special import ndtr

import models
from models.oculomotor import (H_RANGE, MIN_TARGET_DISTANCE, NULL_SACCADE, PRIMARY_EYE_BASIS, V_RANGE,
                               OculomotorRangeError, SaccadePlan, fick_matrix, gaze_direction)
from models.saccade_generator import _AMP_STEP_DEG, _TABLE_DT_MS, DETECTION_THRESHOLD_DEG_S, BurstGenerator

__all__ = ["BatchedPlanner", "PlanBatch", "SettledReset", "burst_profiles"]

_KNOT_MS = 0.5  # the eye-position signal's knots (SaccadePlan.eye_position_signal)


def _listing(hv: np.ndarray) -> np.ndarray:
    """(..., 2) Fick (h, v) -> (..., 3) with Listing torsion (models.oculomotor._listing)."""
    return np.concatenate([hv, 2.0 * np.arctan(np.tan(hv[..., :1] / 2) * np.tan(hv[..., 1:] / 2))], axis=-1)


# ---------------------------------------------------------------------------------------- profiles
@dataclass
class _BurstTable:
    """The burst generator's normalised profile table, amplitude-major (A, 3, K), and per pair of
    neighbouring amplitudes the number of time steps past which no interpolated profile between them
    can matter (it has settled, is below the detection speed and below its peak speed)."""

    amps: np.ndarray
    norm: np.ndarray
    bound: np.ndarray


_TABLES: dict = {}
_LOCK = threading.Lock()


def _burst_table(gen: BurstGenerator) -> _BurstTable:
    key = tuple(getattr(gen, f.name) for f in fields(gen))
    with _LOCK:
        tab = _TABLES.get(key)
        if tab is not None:
            return tab
    amps, norm, _ = gen._table()
    normT = np.ascontiguousarray(np.moveaxis(norm, 2, 0))  # (A, 3, K)
    K = normT.shape[2]
    rates = np.gradient(normT, _TABLE_DT_MS, axis=2)
    bound = np.empty(len(amps) - 1, np.intp)
    tol = 1e-9
    for j in range(len(amps) - 1):
        cols = (1, 1) if j == 0 else (j, j + 1)  # below 0.25 deg the profile is the 0.25 deg one
        top = amps[j + 1]
        p = normT[list(cols)]
        r = rates[list(cols), 0]
        # an interpolated profile is a convex combination of the two columns: its shortfall 1 - p and
        # its rate never exceed the larger of theirs, and its amplitude never exceeds ``top``
        unsettled = (1.0 - p).max(axis=(0, 1)) * top >= gen.settle_deg * (1 - tol)
        moving = np.abs(r).max(axis=0) * top * 1000.0 > DETECTION_THRESHOLD_DEG_S * (1 - tol)
        floor = np.minimum(r[0], r[1]).max()  # the interpolated peak rate is at least this
        peak = r.max(axis=0) >= floor - tol * abs(floor) if floor > 0 else np.ones(K, bool)
        need = np.flatnonzero(unsettled | moving | peak)
        bound[j] = min(K, (need[-1] + 4) if len(need) else 4)
    tab = _BurstTable(amps, normT, bound)
    with _LOCK:
        _TABLES[key] = tab
    return tab


class _Profiles:
    """Normalised profiles of n saccades (the profile interface of ``models.SaccadeProfile``, batched):
    ``onset_ms``, ``offset_ms``, ``duration_ms``, ``settle_ms``, ``peak_velocity_deg_s`` (n,) and
    :meth:`position` (n, ...) per plant."""

    amplitude_deg: np.ndarray

    def position(self, t_rel: np.ndarray, plant) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError


class _BurstProfiles(_Profiles):
    def __init__(self, gen: BurstGenerator, amp_deg: np.ndarray) -> None:
        tab = _burst_table(gen)
        amp = np.asarray(amp_deg, float)
        if amp.size and not (np.isfinite(amp).all() and amp.min() >= 0 and amp.max() <= 90.0):
            raise OculomotorRangeError("saccade amplitudes must lie in [0, 90] deg for the burst generator")
        self.amplitude_deg, self._tab = amp, tab
        amps, normT = tab.amps, tab.norm
        j = np.minimum((amp / _AMP_STEP_DEG).astype(np.intp), len(amps) - 2)
        w = (amp - amps[j]) / _AMP_STEP_DEG
        first = j == 0
        # below 0.25 deg the profile is the 0.25 deg column itself: weight 0 on a second copy of it
        # ((1 - 0) a + 0 a == a exactly)
        self._lo, self._hi = np.where(first, 1, j), np.where(first, 1, j + 1)
        self._weff = np.where(first, 0.0, w)
        self._K = normT.shape[2]
        from ._planner_kernels import profile_marks

        marks = np.empty((len(amp), 4))
        profile_marks(normT, _TABLE_DT_MS, self._lo, self._hi, self._weff, amp, tab.bound[j],
                      DETECTION_THRESHOLD_DEG_S, gen.settle_deg, marks)
        self.onset_ms, self.offset_ms, self.settle_ms, self.peak_velocity_deg_s = marks.T.copy()
        self.duration_ms = self.offset_ms - self.onset_ms

    def position(self, t_rel: np.ndarray, plant) -> np.ndarray:
        """Normalised position of ``plant`` ((n,) or an int) at ``t_rel`` (n, ...) ms after burst onset
        (``SaccadeProfile.position``: the table is read only where the saccade is under way)."""
        K, flat = self._K, self._tab.norm.ravel()
        t_rel = np.asarray(t_rel, float)
        extra = (1,) * (t_rel.ndim - 1)
        col = (-1,) + extra
        settle = self.settle_ms.reshape(col)
        done = (t_rel >= settle) | (t_rel >= (K - 1) * _TABLE_DT_MS)
        out = np.where(t_rel <= 0, 0.0, 1.0)
        zero = self.amplitude_deg <= 0
        live = (t_rel > 0) & ~done & ~zero.reshape(col)
        if live.any():
            x = np.clip(t_rel[live] / _TABLE_DT_MS, 0.0, K - 1.0)
            i = np.minimum(x.astype(np.intp), K - 2)
            frac = x - i
            lo, hi, w = self._lo, self._hi, self._weff
            pl = np.broadcast_to(np.asarray(plant), lo.shape)
            rows = np.broadcast_to(np.arange(len(lo)).reshape(col), t_rel.shape)[live]
            base_lo, base_hi, ww = ((lo * 3 + pl) * K)[rows] + i, ((hi * 3 + pl) * K)[rows] + i, w[rows]
            pi = (1 - ww) * flat[base_lo] + ww * flat[base_hi]
            pi1 = (1 - ww) * flat[base_lo + 1] + ww * flat[base_hi + 1]
            out[live] = pi + frac * (pi1 - pi)
        return np.where(zero.reshape(col), (t_rel >= 0).astype(float), out)


class _LegacyProfiles(_Profiles):
    """``models.oculomotor._LegacyProfile`` (the analytic main sequence), batched."""

    def __init__(self, ms: models.MainSequence, amp_deg: np.ndarray) -> None:
        amp = np.asarray(amp_deg, float)
        self.amplitude_deg, self._ms = amp, ms
        self.duration_ms = np.array([ms.duration_ms(a) for a in amp])
        self.settle_ms = np.array([ms.settle_ms(a) for a in amp])
        self.peak_velocity_deg_s = np.array([ms.peak_velocity_deg_s(a) for a in amp])
        self.onset_ms, self.offset_ms = np.zeros(len(amp)), self.duration_ms

    def position(self, t_rel: np.ndarray, plant) -> np.ndarray:
        ms = self._ms
        t_rel = np.asarray(t_rel, float)
        extra = (1,) * (t_rel.ndim - 1)
        amp = self.amplitude_deg.reshape((-1,) + extra)
        t = np.maximum(t_rel, 0.0)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            A = 1.0 / -np.expm1(-amp / ms.m0_deg)
            x = (ms.vpk_deg_per_ms * t - amp) / ms.m0_deg
            pos = ms.m0_deg * (np.log(A) + ms.vpk_deg_per_ms * t / ms.m0_deg - np.logaddexp(0.0, np.log(A) + x))
            s = pos / amp
        out = np.where(t_rel >= self.settle_ms.reshape((-1,) + extra), 1.0, s)
        return np.where(amp <= 0, (t_rel >= 0).astype(float), out)


def burst_profiles(gen: BurstGenerator, amp_deg) -> _Profiles:
    """The profiles of ``gen`` for amplitudes ``amp_deg`` (n,) in [0, 90] deg, as arrays
    (``BurstGenerator.profile`` batched: ``onset_ms``, ``offset_ms``, ``duration_ms``, ``settle_ms``,
    ``peak_velocity_deg_s`` and ``position(t_rel, plant)``)."""
    return _BurstProfiles(gen, np.atleast_1d(np.asarray(amp_deg, float)))


# ------------------------------------------------------------------------------------------- plans
class PlanBatch:
    """n saccade plans as arrays (``models.SaccadePlan``'s fields and trajectory, batched).

    Fields: ``onset_ms`` (n,) int; ``start``, ``end``, ``intended_end``, ``signal_start`` (n, 2, 3)
    Fick angles; ``amplitude``, ``intended_amplitude`` (n,) rad; ``target``, ``intended_target``
    (n, 3) world points. Derived: ``settle_ms``, ``end_ms``, ``duration_ms``, ``peak_velocity``
    (rad/s), ``efference_copy``, ``efference_copy_eye``, ``executed_rotation`` (n, 2, 3, 3),
    ``endpoint_error_deg`` (n, 2)."""

    def __init__(self, head: models.Head, onset_ms, start, end, intended_end, amplitude, intended_amplitude,
                 signal_start, target, intended_target) -> None:
        self.onset_ms = np.asarray(onset_ms, np.int64)
        self.start, self.end, self.intended_end = (np.asarray(a, float) for a in (start, end, intended_end))
        self.signal_start = np.asarray(signal_start, float)
        self.amplitude, self.intended_amplitude = np.asarray(amplitude, float), np.asarray(intended_amplitude, float)
        self.target, self.intended_target = np.asarray(target, float), np.asarray(intended_target, float)
        self.n = n = len(self.onset_ms)
        self.legacy = head.saccade_model == "legacy"
        self._eps = head.eye_position
        self.vergence = None if self.legacy else head.vergence
        self._amp_deg = np.rad2deg(self.amplitude)
        self._int_deg = np.rad2deg(self.intended_amplitude)
        if self.legacy:
            self.generator = head.main_sequence
            self._prof = _LegacyProfiles(head.main_sequence, self._int_deg)
        else:
            self.generator = head.generator
            if n and self._int_deg.max() > 90.0:
                raise OculomotorRangeError("saccade amplitude exceeds the generator's 90 deg")
            self._prof = _BurstProfiles(head.generator, self._int_deg)
        R0, R1, Ri = (fick_matrix(a[..., 0], a[..., 1], a[..., 2]) for a in (self.start, self.end, self.intended_end))
        R0T = np.swapaxes(R0, -1, -2)
        self.executed_rotation = R1 @ R0T
        self.efference_copy = Ri @ R0T
        B = PRIMARY_EYE_BASIS
        self.efference_copy_eye = B.T @ R0T @ Ri @ B
        self._parts = {"executed": self._decompose(self.end), "intended": self._decompose(self.intended_end)}
        verg = np.maximum(np.abs(self._parts["executed"][2]).max(axis=1), np.abs(self._parts["intended"][2]).max(axis=1))
        settle = self._prof.settle_ms
        if self.vergence is not None:
            settle = np.maximum(settle, self._vergence_settle(np.rad2deg(verg)))
        self.settle_ms = settle.astype(float)
        self.end_ms = (self.onset_ms + np.ceil(self.settle_ms)).astype(np.int64)
        self.duration_ms = self._prof.duration_ms
        scale = np.where(self._int_deg > 0, self._amp_deg / np.where(self._int_deg > 0, self._int_deg, 1.0), 0.0)
        self.peak_velocity = np.deg2rad(self._prof.peak_velocity_deg_s * scale)
        g1 = gaze_direction(self.end[:, :, 0], self.end[:, :, 1]) if n else np.zeros((0, 2, 3))
        g0 = gaze_direction(self.intended_end[:, :, 0], self.intended_end[:, :, 1]) if n else np.zeros((0, 2, 3))
        self.endpoint_error_deg = np.degrees(np.arccos(np.clip((g0 * g1).sum(axis=-1), -1.0, 1.0)))

    def _decompose(self, end: np.ndarray) -> tuple:
        """Per plan: version (n,), vertical displacements (n, 2), vergence (n, 2), plants (n, 2)."""
        d = end[:, :, :2] - self.start[:, :, :2]
        version = d[:, :, 0].mean(axis=1)
        vergence = d[:, :, 0] - version[:, None]
        plants = np.where((version > 0)[:, None], [2, 1], [1, 2])
        plants = np.where(((version == 0) | self.legacy)[:, None], 0, plants)
        return version, d[:, :, 1], vergence, plants

    def _vergence_settle(self, change_deg: np.ndarray) -> np.ndarray:
        """``VergenceDynamics.settle_ms``, batched."""
        vd, settle_deg = self.vergence, self.generator.settle_deg
        off = self._prof.offset_ms
        # math.log per element, as VergenceDynamics.settle_ms (its result feeds ceil(settle) and so end_ms)
        need = vd.tau_ms * np.array([math.log(c / settle_deg) if c > settle_deg else 0.0 for c in change_deg])
        fast = off * vd.saccade_speedup
        out = np.where(need <= fast, need / vd.saccade_speedup, off + (need - fast))
        return np.where(change_deg <= settle_deg, 0.0, out)

    def _hv(self, tr: np.ndarray, which: str) -> np.ndarray:
        """(h, v) (n, T, 2 eyes, 2) at times ``tr`` (n, T) after onset (``SaccadePlan._hv`` without rates)."""
        version, dv, verg, plants = self._parts[which]
        P = self._prof
        col = (slice(None), None)
        s_nom = P.position(tr, 0)
        if self.vergence is None:
            r = s_nom
        else:
            vd = self.vergence
            off = P.offset_ms[col]
            fast = np.clip(tr, 0.0, off) * vd.saccade_speedup
            slow = np.maximum(tr - off, 0.0)
            r = -np.expm1(-(fast + slow) / vd.tau_ms)
        h, v = [], []
        for e in range(2):
            pl = plants[:, e]
            s = s_nom if not pl.any() else np.where((pl == 0)[col], s_nom, P.position(tr, np.maximum(pl, 1)))
            h.append(self.start[:, e, 0][col] + version[col] * s + verg[:, e][col] * r)
            v.append(self.start[:, e, 1][col] + dv[:, e][col] * s_nom)
        hv = np.stack([np.stack(h, -1), np.stack(v, -1)], -1)
        done = (tr >= self.settle_ms[col])[..., None, None]
        end = (self.end if which == "executed" else self.intended_end)[:, None, :, :2]
        return np.where(done, end, hv)

    def angles(self, t_ms: np.ndarray) -> np.ndarray:
        """Executed Fick angles (n, T, 2, 3) at absolute times ``t_ms`` (n, T) (``SaccadePlan.angles``)."""
        return _listing(self._hv(np.asarray(t_ms, float) - self.onset_ms[:, None], "executed"))

    def _kernel_args(self, which: str) -> tuple:
        """The arguments of ``_planner_kernels``' trajectory of these (burst generator) plans."""
        version, dv, verg, plants = self._parts[which]
        P, vd = self._prof, self.vergence
        return (P._tab.norm, _TABLE_DT_MS, P._lo, P._hi, P._weff, P.amplitude_deg <= 0, P.settle_ms, self.settle_ms,
                P.offset_ms, vd.tau_ms, vd.saccade_speedup, True, version, dv, verg, plants.astype(np.intp),
                self.start, self.end if which == "executed" else self.intended_end)

    def command_table(self) -> tuple[np.ndarray, np.ndarray]:
        """The executed angles (n, T, 6) at every whole ms from each plan's onset to its ``end_ms`` (then
        held), and the rows in use (n,)."""
        from ._planner_kernels import trajectories

        count = self.end_ms - self.onset_ms + 1
        T = int(count.max()) if self.n else 1
        if self.legacy:
            t = self.onset_ms[:, None] + np.minimum(np.arange(T)[None, :], count[:, None] - 1).astype(float)
            return self.angles(t).reshape(self.n, T, 6), count
        out = np.empty((self.n, T, 6))
        trajectories(*self._kernel_args("executed"), 1.0, count, out)
        return out, count

    def eye_position_signal(self, t_ms: np.ndarray) -> np.ndarray:
        """The eye-position signal (n, m, 2, 3) of each plan at absolute times ``t_ms`` (n, m)
        (``SaccadePlan.eye_position_signal``)."""
        eps = self._eps
        t = (np.asarray(t_ms, float) - self.onset_ms[:, None]) - eps.delay_ms
        count = np.ceil((self.settle_ms + _KNOT_MS) / _KNOT_MS).astype(np.int64)  # len(np.arange(0, settle + 0.5, 0.5))
        if self.legacy:
            smooth = self._smooth_numpy(t, count)
        else:
            from ._planner_kernels import signals

            smooth = np.empty(t.shape + (4,))
            signals(*self._kernel_args("intended"), _KNOT_MS, count, t, eps.sigma_ms, smooth)
        start = self.signal_start[:, None, :, :2]
        hv = start + (self.intended_end[:, None, :, :2] - start) * smooth.reshape(t.shape + (2, 2))
        return _listing(hv)

    def _smooth_numpy(self, t: np.ndarray, count: np.ndarray) -> np.ndarray:
        """``EyePositionSignal.smooth`` of the normalised intended profiles, in numpy (the legacy plans)."""
        K = int(count.max()) if self.n else 1
        knots = np.broadcast_to(np.arange(K) * _KNOT_MS, (self.n, K))
        hv = self._hv(knots, "intended")
        total = (self.intended_end - self.start)[:, None, :, :2]
        s_nom = self._prof.position(knots, 0)[..., None, None]
        with np.errstate(invalid="ignore", divide="ignore"):
            norm = np.where(total != 0, (hv - self.start[:, None, :, :2]) / total, s_nom)
        norm = norm.reshape(self.n, K, 4)
        rows = np.arange(self.n)
        last = norm[rows, count - 1]
        norm = np.where((np.arange(K)[None, :] >= count[:, None])[..., None], last[:, None, :], norm)
        mid = 0.5 * (knots[0, 1:] + knots[0, :-1])
        z = (t[..., None] - mid) / self._eps.sigma_ms
        tail = ndtr((t - ((count - 1) * _KNOT_MS)[:, None]) / self._eps.sigma_ms)[..., None] * (1.0 - last[:, None, :])
        return np.einsum("nmk,nkc->nmc", ndtr(z), np.diff(norm, axis=1)) + tail

    def plan(self, k: int, head: models.Head) -> SaccadePlan:
        """Plan ``k`` as a ``models.SaccadePlan`` (as ``head`` would have planned it)."""
        return SaccadePlan(onset_ms=int(self.onset_ms[k]), start_angles=self.start[k], end_angles=self.end[k],
                           amplitude=float(self.amplitude[k]), generator=self.generator, target=self.target[k],
                           intended_target=self.intended_target[k], intended_end_angles=self.intended_end[k],
                           intended_amplitude=float(self.intended_amplitude[k]), vergence=self.vergence,
                           eye_position=head.eye_position, signal_start_angles=self.signal_start[k])


def _concat(batches: list[PlanBatch], order: np.ndarray, head: models.Head) -> PlanBatch:
    names = ("onset_ms", "start", "end", "intended_end", "amplitude", "intended_amplitude", "signal_start",
             "target", "intended_target")
    cols = {k: np.concatenate([getattr(b, k) for b in batches])[order] for k in names}
    return PlanBatch(head, **cols)


# ----------------------------------------------------------------------------------------- planner
class BatchedPlanner:
    """The oculomotor state and saccade planning of N worlds (see the module docstring).

    One ``models.Head`` (``head``) serves every world as a scratch copy: the env resets it for a world
    (scene layout, fixation, task: :class:`SettledReset`) and hands the result over with
    :meth:`take_reset`; it also plans, from the world's state, the saccades that need the single
    env's code (vergence actions with endpoint noise). State per world: the clock ``time_ms``, the
    held eye angles, the fixation point, the eye-position signal now and the last plan behind it,
    the generator of the world's endpoint noise (``rngs``) and its scene's movable objects
    (``mocap_pos``, ``mocap_quat``).
    """

    def __init__(self, head: models.Head, num_worlds: int) -> None:
        self.head = head
        self.num_worlds = n = int(num_worlds)
        self._centres = head._eye_centres_head
        self._c = self._centres.mean(axis=0)
        x, R = head._head_pose()
        self._x, self._R = x, R
        self.time_ms = np.zeros(n, np.int64)
        self.hold = np.zeros((n, 2, 3))
        self.signal_hold = np.zeros((n, 2, 3))
        self.fix_head = np.zeros((n, 3))
        self.signal_now = np.zeros((n, 2, 3))  # the eye-position signal at time_ms
        self.rngs: list[np.random.Generator | None] = [None] * n
        d = head.data
        self.mocap_pos = np.zeros((n,) + d.mocap_pos.shape)
        self.mocap_quat = np.zeros((n,) + d.mocap_quat.shape)
        #: each world's joints, velocities and set-points at its last reset (what the physics loads)
        self.qpos, self.qvel, self.ctrl = (np.zeros((n,) + getattr(d, k).shape) for k in ("qpos", "qvel", "ctrl"))
        self._last: list[tuple[PlanBatch, int] | None] = [None] * n

    @property
    def cyclopean_position(self) -> np.ndarray:
        """World position of the cyclopean eye (``models.Head.cyclopean_position`` at reset)."""
        return self._world(self._c[None])[0]

    # ------------------------------------------------------------------ state
    def take_reset(self, i: int) -> None:
        """Make world ``i``'s state that of the (just reset) head: clock, angles, fixation, signal,
        generator and the positions of the scene's movable objects."""
        head = self.head
        if head._plan is not None or head._signal_plan is not None:
            raise RuntimeError("take_reset expects a freshly reset head (no saccade planned yet)")
        self.time_ms[i] = head.time_ms
        self.hold[i] = head._hold
        self.signal_hold[i] = head._signal_hold
        self.fix_head[i] = head._fix_head
        self.signal_now[i] = head._signal_hold
        self.rngs[i] = head._rng
        d = head.data
        self.mocap_pos[i], self.mocap_quat[i] = d.mocap_pos, d.mocap_quat
        self.qpos[i], self.qvel[i], self.ctrl[i] = d.qpos, d.qvel, d.ctrl
        self._last[i] = None

    def eye_position_signal(self) -> np.ndarray:
        """Every world's eye-position signal now (N, 2, 3) (``models.Head.eye_position_signal``)."""
        return self.signal_now.copy()

    def _sync_head(self, i: int) -> models.Head:
        """The head, brought to world i's state (to plan with the single env's code; its draws of
        endpoint noise come from the world's generator)."""
        head = self.head
        head._rng = self.rngs[i]
        head.time_ms = int(self.time_ms[i])
        head._plan, head._table = None, None
        head._hold = self.hold[i].copy()
        head._signal_hold = self.signal_hold[i].copy()
        head._fix_head = self.fix_head[i].copy()
        last = self._last[i]
        head._signal_plan = None if last is None else last[0].plan(last[1], head)
        return head

    # ------------------------------------------------------------------ planning
    def plan(self, worlds: np.ndarray, hv: np.ndarray, factor: np.ndarray) -> tuple[PlanBatch, np.ndarray]:
        """Plan the saccade of each of ``worlds`` (m,) by Fick increments ``hv`` (m, 2) (rad) with the
        fixation distance scaled by ``factor`` (m,), as ``envs.saccade_env.plan_clipped`` does. Returns
        the plans (in the order of ``worlds``) and whether each was shortened to the oculomotor range."""
        from .saccade_env import plan_clipped

        worlds = np.asarray(worlds, np.intp)
        m = len(worlds)
        hv = np.asarray(hv, float).reshape(m, 2)
        factor = np.asarray(factor, float).reshape(m)
        head = self.head
        noise = head.endpoint_noise
        # vergence actions with endpoint noise are planned by the single env's code, world by world
        fast = np.ones(m, bool) if noise == 0 else factor == 1.0
        clipped = np.zeros(m, bool)
        hv2, factor2 = hv.copy(), factor.copy()
        f_idx = np.flatnonzero(fast)
        targets, row = None, np.full(m, -1)
        if len(f_idx):
            targets = self._targets(worlds[f_idx], hv[f_idx], factor[f_idx])
            row[f_idx] = np.arange(len(f_idx))
            _, _, _, amp, reach, ok, _ = targets
            drew = (noise > 0) & reach & (amp > NULL_SACCADE)  # Head._plan_head drew before failing
            fast[f_idx[~ok & drew]] = False  # (only past the generator's 90 deg): replayed world by world
            out = f_idx[~ok & ~drew]
            if len(out):  # shortened to the range's edge: plan_clipped's bisection, all such worlds at once
                h_c, f_c, burn, odd = self._bisect(worlds[out], hv[out], factor[out])
                fast[out[odd]] = False
                keep = ~odd
                hv2[out[keep]], factor2[out[keep]] = h_c[keep], f_c[keep]
                clipped[out[keep]] = True
                for w, k in zip(worlds[out[keep]], burn[keep]):  # the draws of the attempts before the last
                    for _ in range(k):
                        self.rngs[w].normal(0.0, 1.0, size=2)  # the same stream whatever the scale
                redo = out[keep]  # their targets, from the shortened increments
                for arr, new in zip(targets, self._targets(worlds[redo], hv2[redo], factor2[redo])):
                    arr[row[redo]] = new
        batches, order = [], []
        f_idx = np.flatnonzero(fast)
        if len(f_idx) or m == 0:
            known = None if targets is None else tuple(a[row[f_idx]] for a in targets)
            b, ok = self._plan_fast(worlds[f_idx], hv2[f_idx], factor2[f_idx], known)
            if not ok.all():  # pragma: no cover - the bisection keeps only reachable attempts
                raise RuntimeError("a clipped saccade left the oculomotor range")
            batches.append(b)
            order.append(f_idx)
        slow = np.flatnonzero(~fast)
        if len(slow):
            plans = []
            for k in slow:
                p, clipped[k] = plan_clipped(self._sync_head(worlds[k]), hv[k, 0], hv[k, 1], factor[k])
                plans.append(p)
            batches.append(PlanBatch(head, *(np.array([getattr(p, a) for p in plans]) for a in (
                "onset_ms", "start_angles", "end_angles", "intended_end_angles", "amplitude", "intended_amplitude",
                "signal_start_angles", "target", "intended_target"))))
            order.append(slow)
        order = np.concatenate(order)
        inverse = np.empty(m, np.intp)
        inverse[order] = np.arange(m)
        plans = batches[0] if len(batches) == 1 and np.array_equal(order, np.arange(m)) else _concat(batches, inverse, head)
        return plans, clipped

    def _world(self, p_head: np.ndarray) -> np.ndarray:
        return self._x + p_head @ self._R.T

    def _head(self, p_world: np.ndarray) -> np.ndarray:
        return (p_world - self._x) @ self._R

    def _fixation(self, p_head: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``models.fixation_angles`` batched: (m, 2, 3) angles and whether each target is reachable."""
        d = p_head[:, None, :] - self._centres[None]
        dist = np.linalg.norm(d, axis=2)
        h = np.arctan2(-d[..., 1], d[..., 0])
        v = np.arctan2(d[..., 2], np.hypot(d[..., 0], d[..., 1]))
        ok = (np.all(dist >= MIN_TARGET_DISTANCE, axis=1) & np.all(np.abs(h) <= H_RANGE + 1e-9, axis=1)
              & np.all(np.abs(v) <= V_RANGE + 1e-9, axis=1) & np.isfinite(p_head).all(axis=1))
        return _listing(np.stack([h, v], -1)), ok

    def _cdir(self, p: np.ndarray) -> np.ndarray:
        d = p - self._c
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def _targets(self, worlds: np.ndarray, hv: np.ndarray, factor: np.ndarray) -> tuple:
        """What ``Head.plan_saccade`` (then ``plan_saccade_to`` where factor != 1) aims at, before any noise:
        head-frame targets, world targets, fixation angles, amplitudes; ``reach``: the targets pass
        ``Head._plan_head``'s checks made before it draws endpoint noise (the eyes can fixate them);
        ``ok``: the plan is made (also within the burst generator's 90 deg, checked after the draw)."""
        c = self._c
        legacy = self.head.saccade_model == "legacy"
        cd0 = self._cdir(self.fix_head[worlds])
        d = self.fix_head[worlds] - c
        dist = np.linalg.norm(d, axis=1)
        g = d / dist[:, None]
        H, V = np.arctan2(-g[:, 1], g[:, 0]), np.arcsin(g[:, 2])
        p_head = c + dist[:, None] * gaze_direction(H + hv[:, 0], V + hv[:, 1])
        intended_world = self._world(p_head)
        _, reach = self._fixation(p_head)
        scaled = factor != 1.0
        if scaled.any():  # plan_saccade_to(c + factor (intended_target - c)) from the cyclopean eye
            amp1 = np.arccos(np.clip((cd0[scaled] * self._cdir(p_head[scaled])).sum(axis=1), -1, 1))
            if not legacy:  # the first plan (plan_saccade) must be made too
                reach[np.flatnonzero(scaled)[np.rad2deg(amp1) > 90.0]] = False
            cw = self._world(c[None])[0]
            pw = cw + factor[scaled, None] * (intended_world[scaled] - cw)
            intended_world[scaled] = pw
            p_head[scaled] = self._head(pw)
        end, reach2 = self._fixation(p_head)
        reach &= reach2
        amp = np.arccos(np.clip((cd0 * self._cdir(p_head)).sum(axis=1), -1, 1))
        ok = reach if legacy else reach & (np.rad2deg(amp) <= 90.0)
        return p_head, intended_world, end, amp, reach, ok, cd0

    def _bisect(self, worlds: np.ndarray, hv: np.ndarray, factor: np.ndarray) -> tuple:
        """``plan_clipped``'s bisection on the saccade's length, for all ``worlds`` at once. Returns the
        increments and factors of the last attempt made (none: a null saccade, ``plan_saccade(0, 0)``),
        the number of endpoint-noise draws the attempts before it made (``Head._plan_head`` draws at every
        attempt that reaches its target; the last attempt's draw is ``_plan_fast``'s), and the worlds
        whose attempts drew and then failed (past 90 deg: left to the single env's code)."""
        m = len(worlds)
        noise = self.head.endpoint_noise > 0
        lo, hi, best = np.zeros(m), np.ones(m), np.full(m, -1.0)
        wins, last_drew, odd = np.zeros(m, np.int64), np.zeros(m, bool), np.zeros(m, bool)
        for _ in range(10):
            mid = (lo + hi) / 2
            _, _, _, amp, reach, ok, _ = self._targets(worlds, hv * mid[:, None], factor)
            drew = noise & reach & (amp > NULL_SACCADE)
            odd |= drew & ~ok
            wins += drew & ok
            last_drew = np.where(ok, drew, last_drew)
            best, lo, hi = np.where(ok, mid, best), np.where(ok, mid, lo), np.where(ok, hi, mid)
        none = best < 0
        return (np.where(none[:, None], 0.0, hv * best[:, None]), np.where(none, 1.0, factor),
                wins - last_drew, odd)

    def _plan_fast(self, worlds: np.ndarray, hv: np.ndarray, factor: np.ndarray,
                   targets: tuple | None = None) -> tuple[PlanBatch, np.ndarray]:
        """``Head.plan_saccade`` (then ``plan_saccade_to`` where factor != 1) for worlds whose saccade stays
        in range; returns the plans of those worlds and the mask of them. ``targets``: ``_targets`` of
        these arguments when already computed."""
        c = self._c
        p_head, intended_world, end, amp, _, ok, cd0 = targets or self._targets(worlds, hv, factor)
        idx = np.flatnonzero(ok)
        w = worlds[idx]
        p_head, intended_world, end, amp = p_head[idx], intended_world[idx], end[idx], amp[idx]
        intended_end, intended_amp = end.copy(), amp.copy()
        end_point = p_head.copy()
        noise = self.head.endpoint_noise
        if noise > 0:  # each world's own generator, as Head._plan_head draws it
            draw = np.flatnonzero(amp > NULL_SACCADE)
            if len(draw):
                dd = p_head[draw] - c
                dd_n = np.linalg.norm(dd, axis=1)
                gg = dd / dd_n[:, None]
                Hn, Vn = np.arctan2(-gg[:, 1], gg[:, 0]), np.arcsin(gg[:, 2])
                dHV = np.array([self.rngs[w[k]].normal(0.0, noise * amp[k], size=2) for k in draw])
                moved = c + dd_n[:, None] * gaze_direction(Hn + dHV[:, 0], Vn + dHV[:, 1])
                e2, ok3 = self._fixation(moved)
                keep = draw[ok3]
                end_point[keep], end[keep] = moved[ok3], e2[ok3]
                amp[draw] = np.arccos(np.clip((cd0[idx][draw] * self._cdir(end_point[draw])).sum(axis=1), -1, 1))
        plans = PlanBatch(self.head, self.time_ms[w], self.hold[w], end, intended_end, amp, intended_amp,
                          self.signal_now[w], self._world(end_point), intended_world)
        return plans, ok

    # ------------------------------------------------------------------ execution
    def commands(self, plans: PlanBatch) -> tuple[np.ndarray, np.ndarray]:
        """The command tables: each plan's executed angles (m, T, 6) at every whole ms from its onset to
        its ``end_ms`` (then held), and the rows in use per plan (m,) (``PlanBatch.command_table``)."""
        return plans.command_table()

    def start(self, worlds: np.ndarray, plans: PlanBatch, advance_ms: np.ndarray) -> None:
        """Make ``plans`` the worlds' saccades and advance their clocks by ``advance_ms`` (past each plan's
        end): the eyes then hold the endpoint, the signal follows the plan (``Head.start_saccade`` then
        ``step_ms``)."""
        worlds = np.asarray(worlds, np.intp)
        if np.any(self.time_ms[worlds] + advance_ms < plans.end_ms):
            raise ValueError("advance_ms must carry every world past its saccade's end")
        self.fix_head[worlds] = self._head(plans.target)
        self.hold[worlds] = plans.end
        self.signal_hold[worlds] = plans.intended_end
        self.time_ms[worlds] += np.asarray(advance_ms, np.int64)
        self.signal_now[worlds] = plans.eye_position_signal(self.time_ms[worlds, None].astype(float))[:, 0]
        for k, i in enumerate(worlds):
            self._last[i] = (plans, k)



# ------------------------------------------------------------------------------------------- reset
class SettledReset:
    """``models.Head.reset`` without its physics, for the many resets of a batched env.

    A reset fixates the scene's default fixation point and lets the physics settle for 10 ms; only
    the eyes and neck move, so the joints, set-points, clock and oculomotor state come out the same
    in every world, whatever the layout drawn from the world's seed (the mocap bodies: a dots target,
    the search display). This captures that settled state once from ``head`` and applies it with
    each world's own layout. Usable (``usable``) when the fixation point is not moved by the layout;
    ``tests/test_batched_planner.py`` checks the result against ``Head.reset`` in every scene.
    """

    def __init__(self, head: models.Head) -> None:
        import mujoco

        scene = head.scene
        fix = scene.default_fixation
        moved = scene.layout(np.random.default_rng(0)).keys() if scene.layout is not None else ()
        self.usable = not (isinstance(fix, str) and fix in moved)
        m = head.model
        self._mocap_id = {name: int(m.body_mocapid[m.body(name).id]) for name in moved}
        self._flash_gids = np.array([m.geom(name).id for name in scene.flashes], np.intp)
        blank = mujoco.MjData(head.model)
        mujoco.mj_resetData(head.model, blank)
        self._mocap = blank.mocap_pos.copy(), blank.mocap_quat.copy()
        head.reset(seed=0)
        d = head.data
        self._data = {k: getattr(d, k).copy() for k in ("qpos", "qvel", "ctrl", "act")}
        self._time = float(d.time)
        self._state = {"time_ms": head.time_ms, "_hold": head._hold.copy(), "_signal_hold": head._signal_hold.copy(),
                       "_fix_head": head._fix_head.copy()}

    def apply(self, head: models.Head, seed: int) -> None:
        """Reset ``head`` as ``head.reset(seed=seed)`` would (same joints, set-points, clock, layout,
        visibility of objects and generator state; MuJoCo's other buffers, such as the solver's warm
        start, are not reset)."""
        import mujoco

        if not self.usable:
            head.reset(seed=seed)
            return
        head._seed = seed
        head._rng = np.random.default_rng(seed)
        d = head.data
        for k, v in self._data.items():
            getattr(d, k)[:] = v
        d.time = self._time
        d.mocap_pos[:], d.mocap_quat[:] = self._mocap
        if head.scene.layout is not None:  # Head._set_mocap of each, the names resolved once
            for name, pos in head.scene.layout(head._rng).items():
                d.mocap_pos[self._mocap_id[name]] = pos
        head._plan = head._table = head.last_plan = head._signal_plan = None
        head._flash_off = {}
        m = head.model  # what Head.reset restores of the model: set_visible's changes undone, flashes hidden
        for gid, alpha in head._alpha0.items():
            m.geom_rgba[gid, 3] = alpha
        head._alpha0 = {}
        m.geom_rgba[self._flash_gids, 3] = 0.0
        for k, v in self._state.items():
            setattr(head, k, v.copy() if isinstance(v, np.ndarray) else v)
        mujoco.mj_forward(head.model, head.data)
