"""Saccade plans over N heads, as arrays: the one implementation of the oculomotor model's time course.

``SaccadePlans`` holds n planned binocular saccades (start, executed and intended endpoints, onsets,
amplitudes, targets) and computes, for all of them at once:

* the normalised profiles: the burst generator's tabulated profile interpolated in amplitude
  (``models.BurstGenerator``: its detected onset/offset, settle time and peak speed included) or the
  legacy analytic main sequence (``models.MainSequence``); abducting/adducting plants;
* vergence dynamics (``models.VergenceDynamics``), the per-eye decomposition into version and
  vergence, the settle time (endpoint snap) and the whole millisecond the eyes hold from;
* the executed angles, their rates and the intended angles (Listing torsion at every instant);
* the efference copies and the executed rotation, the endpoint error;
* the eye-position signal (``models.EyePositionSignal``: the intended profile smoothed and delayed).

``models.SaccadePlan`` is N = 1 of it, and the batched env (``envs.BatchedBinocularSaccade``) plans
thousands at once with the same code; the trajectories are the compiled loops of
``models._plan_kernels``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from . import _plan_kernels as K
from .eye_kinematics.fick import PRIMARY_EYE_BASIS, fick_matrix, gaze_direction, with_listing
from .eye_kinematics.main_sequence import MainSequence
from .eye_kinematics.ranges import OculomotorRangeError
from .eye_position_signal import EyePositionSignal
from .saccade_generator import _AMP_STEP_DEG, _TABLE_DT_MS, DETECTION_THRESHOLD_DEG_S, BurstGenerator
from .vergence import VergenceDynamics

__all__ = ["SaccadePlans", "Profiles", "profiles", "KNOT_MS"]

#: Spacing (ms) of the knots at which the eye-position signal samples the intended profile.
KNOT_MS = 0.5


# ---------------------------------------------------------------------------------------- profiles
@dataclass
class _BurstTable:
    """The burst generator's normalised profile table, amplitude-major (A, 3, K), its rates (1/ms), and
    per pair of neighbouring amplitudes the number of time steps past which no interpolated profile
    between them can matter (it has settled, is below the detection speed and below its peak speed)."""

    amps: np.ndarray
    norm: np.ndarray
    rates: np.ndarray
    bound: np.ndarray


@functools.cache  # one table per parameter set (a frozen dataclass: hashed by value)
def _burst_table(gen: BurstGenerator) -> _BurstTable:
    amps, norm, _ = gen._table()
    normT = np.ascontiguousarray(np.moveaxis(norm, 2, 0))  # (A, 3, K)
    Kn = normT.shape[2]
    rates = np.ascontiguousarray(np.gradient(normT, _TABLE_DT_MS, axis=2))
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
        peak = r.max(axis=0) >= floor - tol * abs(floor) if floor > 0 else np.ones(Kn, bool)
        need = np.flatnonzero(unsettled | moving | peak)
        bound[j] = min(Kn, (need[-1] + 4) if len(need) else 4)
    return _BurstTable(amps, normT, rates, bound)


_NO_TABLE = np.zeros((1, 3, 2))


class Profiles:
    """Normalised profiles of n saccades of one trajectory model (``profiles``): ``amplitude_deg``,
    ``onset_ms``, ``offset_ms`` (the 30 deg/s crossings of the burst model; legacy: 0 and the
    duration), ``duration_ms``, ``settle_ms``, ``peak_velocity_deg_s`` (n,), and :meth:`position` /
    :meth:`rate` per plant."""

    def __init__(self, generator: BurstGenerator | MainSequence, amp_deg: np.ndarray) -> None:
        amp = np.atleast_1d(np.asarray(amp_deg, float))
        n = len(amp)
        self.amplitude_deg, self.generator = amp, generator
        self.legacy = isinstance(generator, MainSequence)
        #: per saccade: (lo, hi, weight) of the interpolation in amplitude, amplitude, settle time
        self.prof = np.zeros((n, 5))
        self.prof[:, 3] = amp
        if isinstance(generator, MainSequence):  # self.legacy
            ms = generator
            self.tab = self.rtab = _NO_TABLE
            self.duration_ms = np.array([ms.duration_ms(a) for a in amp])
            self.settle_ms = np.array([ms.settle_ms(a) for a in amp])
            self.peak_velocity_deg_s = np.array([ms.peak_velocity_deg_s(a) for a in amp])
            self.onset_ms, self.offset_ms = np.zeros(n), self.duration_ms
            self.m0, self.vpk = ms.m0_deg, ms.vpk_deg_per_ms
        else:
            if n and not (np.isfinite(amp).all() and amp.min() >= 0 and amp.max() <= 90.0):
                raise OculomotorRangeError("saccade amplitudes must lie in [0, 90] deg for the burst generator")
            tab = _burst_table(generator)
            self.tab, self.rtab = tab.norm, tab.rates
            self.m0 = self.vpk = 0.0
            j = np.minimum((amp / _AMP_STEP_DEG).astype(np.intp), len(tab.amps) - 2)
            w = (amp - tab.amps[j]) / _AMP_STEP_DEG
            first = j == 0
            # below 0.25 deg the profile is the 0.25 deg column itself: weight 0 on a second copy of it
            # ((1 - 0) a + 0 a == a exactly)
            lo, hi = np.where(first, 1, j), np.where(first, 1, j + 1)
            weff = np.where(first, 0.0, w)
            marks = np.empty((n, 4))
            K.profile_marks(
                tab.norm,
                _TABLE_DT_MS,
                lo,
                hi,
                weff,
                amp,
                tab.bound[j],
                DETECTION_THRESHOLD_DEG_S,
                generator.settle_deg,
                marks,
            )
            self.onset_ms, self.offset_ms, self.settle_ms, self.peak_velocity_deg_s = marks.T.copy()
            self.duration_ms = self.offset_ms - self.onset_ms
            self.prof[:, 0], self.prof[:, 1], self.prof[:, 2] = lo, hi, weff
        self.prof[:, 4] = self.settle_ms

    def args(self) -> tuple:
        """The profile arguments of ``models._plan_kernels``' loops."""
        return self.tab, _TABLE_DT_MS, self.prof, self.legacy, self.m0, self.vpk

    def position(self, t_rel: np.ndarray, plant: int = 0) -> np.ndarray:
        """Normalised position of ``plant`` (0 nominal, 1 abducting, 2 adducting) at ``t_rel`` (n, T)
        ms after each burst onset (0 before it, 1 from the settle time)."""
        return self._values(t_rel, plant, False)

    def rate(self, t_rel: np.ndarray, plant: int = 0) -> np.ndarray:
        """d(position)/dt (1/ms) at ``t_rel`` (n, T) (0 outside the movement)."""
        return self._values(t_rel, plant, True)

    def _values(self, t_rel, plant: int, rate: bool) -> np.ndarray:
        t = np.ascontiguousarray(np.asarray(t_rel, float).reshape(len(self.prof), -1))
        out = np.empty(t.shape)
        K.profile_values(
            self.tab, self.rtab, _TABLE_DT_MS, self.prof, self.legacy, self.m0, self.vpk, int(plant), t, rate, out
        )
        return out.reshape(np.shape(t_rel))


def profiles(generator: BurstGenerator | MainSequence, amp_deg) -> Profiles:
    """The normalised profiles of ``generator`` for amplitudes ``amp_deg`` (n,) (burst: 0-90 deg)."""
    return Profiles(generator, amp_deg)


def _cdf_grid(t: np.ndarray, count: np.ndarray, sigma_ms: float) -> tuple[np.ndarray, float]:
    """The Gaussian CDF the eye-position signal weighs its knots' increments with, tabulated once per
    call (``models._plan_kernels.signal_cdf_table``) where the times ``t`` (n, m) (less the delay) lie on
    the knots' midpoints' grid (every ``KNOT_MS / 2``: whole ms after onset with a whole-ms delay, as the
    batched env asks): their differences then take a few thousand values where the kernel would call
    ``erfc`` at every knot of every plan. Returns (table, its first grid point), or an empty table."""
    step = KNOT_MS / 2
    if not t.size or not np.isfinite(t).all() or not np.array_equal(np.floor(t / step) * step, t):
        return _NO_CDF, 0.0
    lo = float(np.floor((t.min() - (int(count.max()) - 1) * KNOT_MS) / step) * step)
    size = int((float(t.max()) - lo) / step) + 1
    if size > t.size * float(count.mean()) / 4:  # few plans or times: the table would cost more than it saves
        return _NO_CDF, 0.0
    cdf = np.empty(size)
    K.signal_cdf_table(lo, step, sigma_ms, cdf)
    return cdf, lo


_NO_CDF = np.zeros(0)


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two float64 arrays hold the same numbers to the bit (-0.0 is not 0.0; NaN is itself):
    then what is computed from them elementwise is the same, and is computed once."""
    return a.shape == b.shape and np.array_equal(
        np.ascontiguousarray(a, np.float64).view(np.uint64), np.ascontiguousarray(b, np.float64).view(np.uint64)
    )


# ------------------------------------------------------------------------------------------- plans
class SaccadePlans:
    """n binocular saccade plans as arrays (``models.SaccadePlan`` is n = 1 of it).

    Fields: ``onset_ms`` (n,) int (burst onset, absolute ms); ``start``, ``end``, ``intended_end``,
    ``signal_start`` (n, 2, 3) Fick angles [eye (left, right), (h, v, t)]; ``amplitude``,
    ``intended_amplitude`` (n,) cyclopean, rad; ``target``, ``intended_target`` (n, 3) world points;
    ``generator`` (a ``BurstGenerator``, or a ``MainSequence`` for the legacy model), ``vergence``
    (``VergenceDynamics``; None for legacy, where vergence follows the saccade's profile) and
    ``eye_position`` (``EyePositionSignal``).

    Derived: ``settle_ms`` (after onset), ``end_ms`` (absolute whole ms the eyes hold from),
    ``duration_ms``, ``offset_ms``, ``movement_onset_ms`` (absolute), ``peak_velocity`` (rad/s),
    ``efference_copy``, ``efference_copy_eye``, ``executed_rotation`` (n, 2, 3, 3),
    ``endpoint_error_deg`` (n, 2).

    Per eye, the horizontal angle is ``h0 + dVersion s_plant(t) + dVergence r(t)`` and the vertical
    ``v0 + dv s(t)``; torsion follows Listing's law at every instant. The profiles are those of the
    executed amplitude (``end``: with motor noise the generator's saccade of the noisy amplitude, so
    executed saccades keep the main sequence); the intended command (the efference copy's time course)
    has those of the intended amplitude.
    """

    def __init__(
        self,
        onset_ms,
        start,
        end,
        intended_end,
        amplitude,
        intended_amplitude,
        signal_start,
        target,
        intended_target,
        *,
        generator: BurstGenerator | MainSequence,
        vergence: VergenceDynamics | None,
        eye_position: EyePositionSignal,
    ) -> None:
        self.onset_ms = np.atleast_1d(np.asarray(onset_ms, np.int64))
        self.n = n = len(self.onset_ms)
        self.start, self.end, self.intended_end, self.signal_start = (
            np.asarray(a, float).reshape(n, 2, 3) for a in (start, end, intended_end, signal_start)
        )
        self.amplitude = np.asarray(amplitude, float).reshape(n)
        self.intended_amplitude = np.asarray(intended_amplitude, float).reshape(n)
        self.target, self.intended_target = (np.asarray(a, float).reshape(n, 3) for a in (target, intended_target))
        self.generator, self.eye_position = generator, eye_position
        self.legacy = isinstance(generator, MainSequence)
        self.vergence = vergence
        self._amp_deg = np.rad2deg(self.amplitude)
        self._int_deg = np.rad2deg(self.intended_amplitude)
        if not self.legacy and n and self._int_deg.max() > 90.0:
            raise OculomotorRangeError(
                f"saccade amplitude {self._int_deg.max():.1f} deg exceeds the generator's 90 deg"
            )
        self.profiles = Profiles(generator, self._int_deg)  # the command's (intended) kinematics
        if not self.legacy and n and self._amp_deg.max() > 90.0:
            raise OculomotorRangeError(
                f"executed saccade amplitude {self._amp_deg.max():.1f} deg exceeds the generator's 90 deg"
            )
        # the executed saccade is the generator's for its own (noisy) amplitude: it keeps the main sequence
        same = np.array_equal(self._amp_deg, self._int_deg)
        self.executed_profiles = prof = self.profiles if same else Profiles(generator, self._amp_deg)
        self._prof = {"executed": prof, "intended": self.profiles}
        # (without motor noise the executed endpoint is the intended one: its rotation is computed once)
        exact = _same_bits(self.end, self.intended_end)
        R0, R1 = (fick_matrix(a[..., 0], a[..., 1], a[..., 2]) for a in (self.start, self.end))
        Ri = (
            R1
            if exact
            else fick_matrix(self.intended_end[..., 0], self.intended_end[..., 1], self.intended_end[..., 2])
        )
        R0T = np.swapaxes(R0, -1, -2)
        self.executed_rotation = R1 @ R0T
        self.efference_copy = Ri @ R0T
        B = PRIMARY_EYE_BASIS
        self.efference_copy_eye = B.T @ R0T @ Ri @ B
        self._parts = {
            "executed": self._decompose(self.end, prof),
            "intended": self._decompose(self.intended_end, self.profiles),
        }
        settle = np.maximum(prof.settle_ms, self.profiles.settle_ms)
        if self.vergence is not None:
            done = None
            for which in ("executed", "intended"):  # each eye's share of the signed convergence
                row = self._parts[which][1]
                share = np.where(row[:, 5] - row[:, 6] >= 0, 1.0, -1.0) * np.abs(row[:, 5:7]).max(axis=1)
                if done is not None and _same_bits(share, done):  # the same settle times (no motor noise)
                    continue
                settle = np.maximum(
                    settle, self.vergence.settle_ms(np.rad2deg(share), prof.offset_ms, generator.settle_deg)
                )
                done = share
        self.settle_ms = np.asarray(settle, float)
        for which in ("executed", "intended"):
            self._parts[which][1][:, 0] = self.settle_ms
        self.end_ms = (self.onset_ms + np.ceil(self.settle_ms)).astype(np.int64)
        self.duration_ms = prof.duration_ms
        self.offset_ms = self.onset_ms + prof.offset_ms
        self.movement_onset_ms = self.onset_ms + prof.onset_ms
        self.peak_velocity = np.deg2rad(prof.peak_velocity_deg_s)
        g1 = gaze_direction(self.end[:, :, 0], self.end[:, :, 1])
        g0 = g1 if exact else gaze_direction(self.intended_end[:, :, 0], self.intended_end[:, :, 1])
        self.endpoint_error_deg = np.degrees(np.arccos(np.clip((g0 * g1).sum(axis=-1), -1.0, 1.0)))

    def _decompose(self, end: np.ndarray, prof: Profiles) -> tuple[np.ndarray, np.ndarray]:
        """Per plan the plants (n, 2) and the kernels' plan row (n, 8): settle time (filled in later),
        saccade offset, version, vertical displacements (2) and vergence (2) of each eye, and the
        vergence time scale (``VergenceDynamics._tau_for`` of the convergence ``vergence_left -
        vergence_right``; 1 for the legacy model)."""
        d = end[:, :, :2] - self.start[:, :, :2]
        version = d[:, :, 0].mean(axis=1)
        vergence = d[:, :, 0] - version[:, None]
        # plant rows: 0 nominal, 1 abducting, 2 adducting; the right eye abducts moving right (h > 0)
        plants = np.where((version > 0)[:, None], [2, 1], [1, 2])
        plants = np.where(((version == 0) | self.legacy)[:, None], 0, plants).astype(np.intp)
        tau = (
            np.ones(self.n)
            if self.vergence is None
            else self.vergence._tau_for(vergence[:, 0] - vergence[:, 1]) * np.ones(self.n)
        )
        row = np.column_stack(
            [np.zeros(self.n), prof.offset_ms if self.n else np.zeros(0), version, d[:, :, 1], vergence, tau]
        )
        return plants, row

    def _args(self, which: str) -> tuple:
        plants, row = self._parts[which]
        vd = self.vergence
        verg_on = vd is not None
        return (
            row,
            verg_on,
            vd.saccade_speedup if vd is not None else 1.0,
            vd.latency_ms if vd is not None else 0.0,
            plants,
            self.start,
            self.end if which == "executed" else self.intended_end,
        )

    def _rel(self, t_ms) -> np.ndarray:
        t = np.asarray(t_ms, float)
        t = t.reshape(self.n, t.size // self.n if self.n else (t.shape[-1] if t.ndim else 1))
        return np.ascontiguousarray(t - self.onset_ms[:, None])

    def angles(self, t_ms, which: str = "executed") -> np.ndarray:
        """Fick angles (n, T, 2, 3) at absolute times ``t_ms`` (n, T) of the executed (what the eyes do)
        or the ``"intended"`` command (noise-free; the efference copy's time course)."""
        t = self._rel(t_ms)
        out = np.empty(t.shape + (2, 3))
        K.angles(*self._prof[which].args(), *self._args(which), t, out)
        return out

    def velocities(self, t_ms) -> np.ndarray:
        """Executed angular rates (rad/ms) of the Fick angles (n, T, 2, 3) at absolute times ``t_ms`` (n, T)."""
        t = self._rel(t_ms)
        out = np.empty(t.shape + (2, 3))
        p = self.executed_profiles
        K.rates(p.tab, p.rtab, _TABLE_DT_MS, p.prof, p.legacy, p.m0, p.vpk, *self._args("executed"), t, out)
        return out

    def command_table(
        self, buffer: np.ndarray | None = None, *, rows: np.ndarray | None = None, num_rows: int | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The executed angles (n, T, 6) at every whole ms from each plan's onset to its ``end_ms`` (then
        held), and the rows in use (n,). ``buffer``: a flat float64 array of at least n T 6 numbers to
        write the table into (its first n T 6, returned as the table's view); None: a new array. A
        reused buffer spares the pages a new table of thousands of worlds must be given by the system
        on each call (about half of the table's time at 4096 worlds on 2 cores).

        ``rows`` (n,) distinct integers below ``num_rows``: the table has ``num_rows`` rows (a batch of
        worlds, some without a plan), plan k's at row ``rows[k]``; the other rows are left as they are
        (unwritten in a new array or buffer: the caller fills them)."""
        count = self.end_ms - self.onset_ms + 1
        T = int(count.max()) if self.n else 1
        if rows is None:
            dest, N = np.arange(self.n), self.n
        else:
            N = int(num_rows) if num_rows is not None else -1
            dest = np.asarray(rows, np.intp).reshape(-1)
            if len(dest) != self.n or N < 0 or (self.n and (dest.min() < 0 or dest.max() >= N)):
                raise ValueError(
                    f"rows must be {self.n} row indices below num_rows; got {len(dest)} rows, num_rows {num_rows}"
                )
            if len(np.unique(dest)) != self.n:
                raise ValueError("rows must be distinct: one row of the table per plan")
        size = N * T * 6
        if buffer is None:
            out = np.empty((N, T, 2, 3))
        elif buffer.dtype != np.float64 or buffer.ndim != 1 or not buffer.flags.c_contiguous or buffer.size < size:
            raise ValueError(
                f"buffer must be a contiguous flat float64 array of at least {size} numbers; got "
                f"{buffer.dtype} {buffer.shape}"
            )
        else:
            out = buffer[:size].reshape(N, T, 2, 3)
        K.command_rows(*self.executed_profiles.args(), *self._args("executed"), count, dest, out)
        return out.reshape(N, T, 6), count

    def eye_position_signal(self, t_ms, eye_position: EyePositionSignal | None = None) -> np.ndarray:
        """The eye-position signal (n, m, 2, 3) of each plan at absolute times ``t_ms`` (n, m): the
        intended trajectory smoothed and delayed (``models.EyePositionSignal``: ``eye_position``, default
        the plans' own), from ``signal_start`` to ``intended_end``; torsion by Listing's law for the
        signal's own gaze."""
        eps = self.eye_position if eye_position is None else eye_position
        t = self._rel(t_ms) - eps.delay_ms
        count = np.ceil((self.settle_ms + KNOT_MS) / KNOT_MS).astype(np.int64)  # len(np.arange(0, settle + 0.5, 0.5))
        smooth = np.empty(t.shape + (4,))
        cdf, lo = _cdf_grid(t, count, eps.sigma_ms)
        K.signals(*self.profiles.args(), *self._args("intended"), KNOT_MS, count, t, eps.sigma_ms, cdf, lo, smooth)
        start = self.signal_start[:, None, :, :2]
        hv = start + (self.intended_end[:, None, :, :2] - start) * smooth.reshape(t.shape + (2, 2))
        return with_listing(hv)

    def take(self, rows) -> SaccadePlans:
        """The plans of ``rows`` (indices) as a new batch."""
        rows = np.asarray(rows, np.intp)
        return SaccadePlans(
            *(getattr(self, k)[rows] for k in _FIELDS),
            generator=self.generator,
            vergence=self.vergence,
            eye_position=self.eye_position,
        )

    @staticmethod
    def concatenate(batches: list[SaccadePlans], order: np.ndarray | None = None) -> SaccadePlans:
        """One batch of the plans of ``batches`` (one model), in ``order`` of their concatenation."""
        b0 = batches[0]
        cols = [np.concatenate([getattr(b, k) for b in batches]) for k in _FIELDS]
        if order is not None:
            cols = [c[order] for c in cols]
        return SaccadePlans(*cols, generator=b0.generator, vergence=b0.vergence, eye_position=b0.eye_position)


_FIELDS = (
    "onset_ms",
    "start",
    "end",
    "intended_end",
    "amplitude",
    "intended_amplitude",
    "signal_start",
    "target",
    "intended_target",
)
