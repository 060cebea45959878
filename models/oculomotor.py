"""Oculomotor plant: binocular fixation geometry, Listing's law and main-sequence saccades.

Pure numpy (no MuJoCo).  Angles are radians unless a name ends in ``_deg``; times are in
milliseconds (``_ms``).

Head frame: x forward (primary gaze direction), y to the head's left, z up.  Eye orientation is
given as Fick angles ``(h, v, t)`` -- the gimbal of ``models/head.xml``::

    R = rot(-z, h) @ rot(-y, v) @ rot(+x, t)

``h > 0`` turns the gaze to the right, ``v > 0`` up, ``t > 0`` turns the top of the eye to the
subject's right.  ``R`` maps eye coordinates at primary position to head coordinates; the eye
frame of the README's conventions is ``x2 = R[:, 0]`` (optical axis), ``x3 = -R[:, 1]`` (right),
``x1 = R[:, 2]`` (up).

Literature:
  * Listing's law: every eye orientation is reached from primary position by a rotation about an
    axis in Listing's plane (the frontal plane, orthogonal to the primary direction); Fick
    torsion is then ``tan(t/2) = tan(h/2) tan(v/2)`` with the signs above
    (Tweed & Vilis 1990; Haslwanter 1995, Vision Res. 35:1727).
  * Main sequence: Van Wetter & Van Opstal (2008), J. Vision 8(14):8,
    ``E(t) = m0 ln[A exp(vpk t / m0) / (1 + A exp((vpk t - T)/m0))]``, ``A = 1/(1 - exp(-T/m0))``,
    ``m0 = 7 deg``, ``vpk = 0.525 deg/ms`` (about 400 deg/s and 57 ms for 10 deg).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np

from conformal import checks

__all__ = ["SACCADE_MODELS", "H_RANGE", "V_RANGE", "T_RANGE", "MAX_PEAK_VELOCITY", "MainSequence",
           "OculomotorRangeError", "SaccadePlan", "fick_matrix", "fick_angles", "listing_torsion", "gaze_direction",
           "rotation_vector", "fixation_angles", "eye_frame_basis"]

H_RANGE = np.deg2rad(45.0)  #: horizontal oculomotor range (+-), radians
V_RANGE = np.deg2rad(35.0)  #: vertical oculomotor range (+-), radians
T_RANGE = np.deg2rad(20.0)  #: Fick-torsion joint range (+-); Listing torsion stays below 15 deg
MAX_PEAK_VELOCITY = np.deg2rad(700.0)  #: physiological ceiling of eye speed, rad/s
MIN_TARGET_DISTANCE = 0.05  #: metres from an eye's rotation centre
#: Saccades no larger than this (rad) are null: no endpoint noise is drawn for them (their amplitude
#: is an arccos near 1, where the last bit of a dot product moves it by ~1e-8 rad)
NULL_SACCADE = 1e-7
#: Trajectory models of ``Head(saccade_model=...)``: the brainstem burst generator (default) and
#: the earlier analytic main-sequence planner.
SACCADE_MODELS = ("burst", "legacy")

_X = np.array([1.0, 0.0, 0.0])
_Y = np.array([0.0, 1.0, 0.0])
_Z = np.array([0.0, 0.0, 1.0])

#: Columns are the head-frame directions of the eye axes (README, conventions) (x1, x2, x3) at primary position.
PRIMARY_EYE_BASIS = np.column_stack([_Z, _X, -_Y])


class OculomotorRangeError(ValueError):
    """A fixation target the eyes cannot reach (outside +-45 deg horizontal / +-35 deg vertical,
    closer than 5 cm, behind the head) or not a finite 3-vector."""


def _rot(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotation matrices about a fixed unit ``axis`` by ``angle`` (any shape) -> (..., 3, 3)."""
    angle = np.asarray(angle, dtype=float)
    c, s = np.cos(angle)[..., None, None], np.sin(angle)[..., None, None]
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + s * k + (1 - c) * (k @ k)


def _angles(**named) -> list[np.ndarray]:
    """Finite real angle arrays (radians) whose shapes broadcast together."""
    out = [checks.array(name, a, kinds="biuf").astype(float) for name, a in named.items()]
    try:
        np.broadcast_shapes(*(a.shape for a in out))
    except ValueError:
        raise ValueError(f"{', '.join(named)} must have shapes that broadcast; got "
                         f"{', '.join(str(a.shape) for a in out)}") from None
    return out


def _rotations(name: str, R, single: bool = False) -> np.ndarray:
    """Finite rotation matrices (..., 3, 3) (orthogonal to 1e-6, det +1), or one (3, 3) if ``single``."""
    r = checks.array(name, R, kinds="biuf", ndim=2 if single else None).astype(float)
    if r.shape[-2:] != (3, 3):
        raise ValueError(f"{name} must be {'a 3x3 rotation matrix' if single else 'rotation matrices (..., 3, 3)'}; "
                         f"got shape {r.shape}")
    if r.size and (np.abs(r @ np.swapaxes(r, -1, -2) - np.eye(3)).max() > 1e-6 or np.linalg.det(r).min() < 0):
        raise ValueError(f"{name} must hold proper rotation matrices (orthogonal, det +1)")
    return r


def fick_matrix(h, v, t) -> np.ndarray:
    """Eye-in-head rotation ``rot(-z,h) rot(-y,v) rot(x,t)`` for finite Fick angles (vectorised)."""
    h, v, t = _angles(h=h, v=v, t=t)
    return _rot(-_Z, h) @ _rot(-_Y, v) @ _rot(_X, t)


def gaze_direction(h, v) -> np.ndarray:
    """Unit gaze (optical-axis) direction in the head frame for finite Fick angles ``h, v``."""
    h, v = np.broadcast_arrays(*_angles(h=h, v=v))
    return np.stack([np.cos(h) * np.cos(v), -np.sin(h) * np.cos(v), np.sin(v)], axis=-1)


def fick_angles(R: np.ndarray) -> np.ndarray:
    """Fick angles ``(h, v, t)`` of eye-in-head rotation(s) ``R`` (..., 3, 3) -> (..., 3)."""
    R = _rotations("R", R)
    g = R[..., :, 0]
    h = np.arctan2(-g[..., 1], g[..., 0])
    v = np.arcsin(np.clip(g[..., 2], -1.0, 1.0))
    M = np.swapaxes(_rot(-_Z, h) @ _rot(-_Y, v), -1, -2) @ R
    t = np.arctan2(M[..., 2, 1], M[..., 1, 1])
    return np.stack([h, v, t], axis=-1)


def listing_torsion(h, v) -> np.ndarray:
    """Fick torsion that puts the eye in Listing's plane: ``tan(t/2) = tan(h/2) tan(v/2)``.

    Derived from the rotation about the axis ``primary x gaze`` (which lies in Listing's plane);
    the tests check it against that construction, not against this formula.
    """
    from ._plan_kernels import listing_torsion as formula  # the formula's one home

    h, v = _angles(h=h, v=v)
    return np.asarray(formula(h, v), float)


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """Rotation vector (axis * angle, radians) of rotation matrix ``R`` (3, 3)."""
    R = _rotations("R", R, single=True)
    angle = np.arccos(np.clip((np.trace(R) - 1) / 2, -1.0, 1.0))
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if angle < 1e-9:
        return 0.5 * w
    return angle * w / (2 * np.sin(angle))


def eye_frame_basis(R: np.ndarray) -> np.ndarray:
    """Head-frame directions of the eye axes (x1 up, x2 optical axis, x3 right) as columns."""
    return np.asarray(R) @ PRIMARY_EYE_BASIS


def _check_point(p, name: str = "target") -> np.ndarray:
    p = checks.array(name, p, kinds="biuf", finite=False).astype(float)
    if p.shape != (3,):
        raise OculomotorRangeError(f"{name} must be a 3-vector (x, y, z) in metres, got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise OculomotorRangeError(f"{name} must be finite, got {p.tolist()}")
    return p


def fixation_angles(target_head: np.ndarray, eye_centres_head: np.ndarray) -> np.ndarray:
    """Fick angles ``(2, 3)`` [eye, (h, v, t)] that make both eyes fixate ``target_head``.

    Each eye's optical axis is aimed from its rotation centre (the nodal point lies on that axis)
    through the target, so vergence follows from depth; torsion obeys Listing's law.
    Raises :class:`OculomotorRangeError` for unreachable or non-finite targets.
    """
    p = _check_point(target_head)
    c = checks.array("eye_centres_head", eye_centres_head, kinds="biuf", ndim=2).astype(float)
    if c.shape[1] != 3 or len(c) == 0:
        raise ValueError(f"eye_centres_head must be (n_eyes, 3) points in metres; got shape {c.shape}")
    from .gaze import fixation_batch

    ang, ok, dist = fixation_batch(p[None], c)
    if ok[0]:
        return ang[0]
    if np.any(dist < MIN_TARGET_DISTANCE):
        raise OculomotorRangeError(
            f"target {p.tolist()} is closer than {MIN_TARGET_DISTANCE} m to an eye; choose a farther point"
        )
    h, v = ang[0, :, 0], ang[0, :, 1]
    raise OculomotorRangeError(
        "target outside the oculomotor range (+-45 deg horizontal, +-35 deg vertical): "
        f"needs h = {np.rad2deg(h).round(1).tolist()} deg, v = {np.rad2deg(v).round(1).tolist()} deg "
        "(left, right eye); move the target or turn the neck"
    )


@dataclass(frozen=True)
class MainSequence:
    """Saccade kinematics of Van Wetter & Van Opstal (2008), J. Vision 8(14):8.

    ``E(t) = m0 ln[A e^{vpk t/m0} / (1 + A e^{(vpk t - T)/m0})]`` with ``A = 1/(1 - e^{-T/m0})``.
    The velocity ``vpk / (1 + A e^{(vpk t - T)/m0})`` peaks at onset at ``vpk (1 - e^{-T/m0})``
    (< vpk <= 700 deg/s). Duration is the time until the speed falls below ``end_velocity_deg_s``
    (20 deg/s, a usual saccade-offset criterion): about 57 ms for 10 deg.
    """

    m0_deg: float = 7.0
    vpk_deg_per_ms: float = 0.525
    end_velocity_deg_s: float = 20.0
    settle_deg: float = 0.01  #: the tail is cut (position snaps to the endpoint) this close to it

    def __post_init__(self):
        object.__setattr__(self, "m0_deg", checks.real("m0_deg", self.m0_deg, 0.0, 100.0, lo_open=True))
        object.__setattr__(self, "vpk_deg_per_ms", checks.real(
            "vpk_deg_per_ms", self.vpk_deg_per_ms, 0.0, round(np.rad2deg(MAX_PEAK_VELOCITY) / 1000.0, 12),
            lo_open=True, hint="peak eye speed never exceeds 700 deg/s"))
        object.__setattr__(self, "end_velocity_deg_s", checks.real(
            "end_velocity_deg_s", self.end_velocity_deg_s, 0.0, 1000.0 * self.vpk_deg_per_ms, lo_open=True,
            hi_open=True, hint="the offset speed lies below the peak speed vpk"))
        object.__setattr__(self, "settle_deg", checks.real("settle_deg", self.settle_deg, 0.0, 1.0, lo_open=True))

    @staticmethod
    def _amp(amp_deg) -> float:
        return checks.real("amp_deg", amp_deg, 0.0, 180.0, hint="a saccade amplitude in degrees")

    def _A(self, amp_deg):
        return 1.0 / -np.expm1(-np.asarray(amp_deg, float) / self.m0_deg)

    def position_deg(self, t_ms, amp_deg: float) -> np.ndarray:
        """E(t) in degrees for ``t_ms`` after onset (0 before onset)."""
        from ._plan_kernels import legacy_position

        t = _times(t_ms)
        return np.asarray(legacy_position(t, self._amp(amp_deg), self.m0_deg, self.vpk_deg_per_ms), float)

    def velocity_deg_per_ms(self, t_ms, amp_deg: float) -> np.ndarray:
        """dE/dt in deg/ms (0 up to and including onset; jumps to the peak just after it)."""
        from ._plan_kernels import legacy_rate

        t = _times(t_ms)
        return np.asarray(legacy_rate(t, self._amp(amp_deg), self.m0_deg, self.vpk_deg_per_ms), float)

    def peak_velocity_deg_s(self, amp_deg: float) -> float:
        """Peak speed (deg/s) = vpk (1 - e^{-T/m0})."""
        amp_deg = self._amp(amp_deg)
        return float(1000.0 * self.vpk_deg_per_ms * -np.expm1(-amp_deg / self.m0_deg))

    def duration_ms(self, amp_deg: float) -> float:
        """Time from onset until the speed falls below ``end_velocity_deg_s``."""
        amp_deg = self._amp(amp_deg)
        if amp_deg <= 0:
            return 0.0
        v, m0 = self.vpk_deg_per_ms, self.m0_deg
        ratio = (v / (self.end_velocity_deg_s / 1000.0) - 1.0) / self._A(amp_deg)
        if ratio <= 0 or self.peak_velocity_deg_s(amp_deg) <= self.end_velocity_deg_s:
            return float(amp_deg / v)
        return float(max((amp_deg + m0 * np.log(ratio)) / v, 0.0))

    def settle_ms(self, amp_deg: float) -> float:
        """Time after onset when T - E(t) < ``settle_deg``; the plan then holds the endpoint."""
        amp_deg = self._amp(amp_deg)
        if amp_deg <= self.settle_deg:
            return 0.0
        # T - E = m0 ln(1 + e^{-x}/A)  =>  e^{-x} = A (e^{d/m0} - 1)
        A = self._A(amp_deg)
        x = -np.log(A * np.expm1(self.settle_deg / self.m0_deg))
        return float((amp_deg + self.m0_deg * x) / self.vpk_deg_per_ms)


def _times(t_ms) -> np.ndarray:
    """Finite real times (ms) as a float array."""
    return checks.array("t_ms", t_ms, kinds="biuf").astype(float)


def _one(name: str, cast, doc: str) -> property:
    """A read-only property: ``cast`` of the first (the only) plan's ``name`` in the plan's batch."""
    return property(lambda self: cast(getattr(self._batch, name)[0]), doc=doc)


@dataclass
class SaccadePlan:
    """A planned binocular saccade, with its efference copy, before the eyes move.

    Times are simulation milliseconds; ``onset_ms`` is absolute (the burst onset: the eyes reach
    30 deg/s a few ms later). Angles are Fick ``(h, v, t)`` per eye, shape ``(2, 3)`` ordered
    (left, right).

    The trajectory comes from ``generator``: a :class:`~models.saccade_generator.BurstGenerator`
    (default; kinematics from the brainstem loop, abducting/adducting plants, slower vergence from
    ``vergence``) or a :class:`MainSequence` (``saccade_model="legacy"``: one analytic profile for
    every component, vergence included, as before). Per eye, the horizontal angle is
    ``h0 + dVersion * s_plant(t) + dVergence * r(t)`` and the vertical ``v0 + dv * s(t)``; torsion
    follows Listing's law at every instant. The executed trajectory is the generator's saccade of
    the executed amplitude (with motor noise, the noisy one: it keeps the main sequence); the intended
    command (the efference copy) that of the intended amplitude.

    ``intended_end_angles`` is where the command aims (default: ``end_angles``);
    ``efference_copy[e]`` is the intended rotation of eye ``e`` in the head frame,
    ``R_intended_end @ R_start.T`` -- the command, unchanged by the motor noise;
    ``efference_copy_eye[e]`` is the same rotation in the pre-saccadic eye frame with axes ordered
    (x1 up, x2 optical axis, x3 right) of the README's conventions. ``executed_rotation`` is the rotation the eyes
    actually make. :meth:`eye_position_signal` is the brain's estimate of eye orientation
    (``models.eye_position_signal``), starting from ``signal_start_angles`` (default: the start).
    """

    onset_ms: int
    start_angles: np.ndarray
    end_angles: np.ndarray
    amplitude: float  #: executed cyclopean amplitude, radians
    generator: object = None  #: BurstGenerator (default) or MainSequence (legacy)
    target: np.ndarray | None = None  #: executed (possibly noisy) world fixation point
    intended_target: np.ndarray | None = None  #: world point asked for, before endpoint noise
    intended_end_angles: np.ndarray | None = None  #: the command's endpoint (default: end_angles)
    intended_amplitude: float | None = None  #: cyclopean amplitude of the command (default: amplitude)
    vergence: object = None  #: VergenceDynamics (default with a BurstGenerator; unused by legacy)
    eye_position: object = None  #: EyePositionSignal timing (default EyePositionSignal())
    signal_start_angles: np.ndarray | None = None  #: where the eye-position signal starts

    def __post_init__(self):
        from .eye_position_signal import EyePositionSignal
        from .saccade_generator import BurstGenerator
        from .vergence import VergenceDynamics

        self.onset_ms = checks.integer("onset_ms", self.onset_ms, 0, None, hint="a whole millisecond")
        for name in ("start_angles", "end_angles", "intended_end_angles", "signal_start_angles"):
            value = getattr(self, name)
            if value is None and name in ("intended_end_angles", "signal_start_angles"):
                continue
            a = checks.array(name, value, kinds="biuf", finite=False)
            if a.shape != (2, 3):
                raise ValueError(f"{name} must be Fick angles of shape (2, 3) [eye, (h, v, t)]; got {a.shape}")
            if not np.all(np.isfinite(a)):
                raise OculomotorRangeError("saccade plan angles must be finite")
            setattr(self, name, a.astype(float))
        if self.intended_end_angles is None:
            self.intended_end_angles = self.end_angles.copy()
        if self.signal_start_angles is None:
            self.signal_start_angles = self.start_angles.copy()
        self.amplitude = checks.real("amplitude", self.amplitude, 0.0, np.pi, hint="radians")
        self.intended_amplitude = (self.amplitude if self.intended_amplitude is None else
                                   checks.real("intended_amplitude", self.intended_amplitude, 0.0, np.pi, hint="radians"))
        if self.generator is None:
            self.generator = BurstGenerator()
        if not isinstance(self.generator, (BurstGenerator, MainSequence)):
            raise checks.InputTypeError(f"generator must be a models.BurstGenerator or a models.MainSequence; "
                                        f"got {type(self.generator).__name__}")
        self.legacy = isinstance(self.generator, MainSequence)
        if self.vergence is None and not self.legacy:
            self.vergence = VergenceDynamics()
        if self.vergence is not None and not isinstance(self.vergence, VergenceDynamics):
            raise checks.InputTypeError(f"vergence must be a models.VergenceDynamics or None; got {type(self.vergence).__name__}")
        if self.eye_position is None:
            self.eye_position = EyePositionSignal()
        if not isinstance(self.eye_position, EyePositionSignal):
            raise checks.InputTypeError(f"eye_position must be a models.EyePositionSignal or None; "
                                        f"got {type(self.eye_position).__name__}")
        for name in ("target", "intended_target"):
            if getattr(self, name) is not None:
                setattr(self, name, _check_point(getattr(self, name), name))
        from .saccade_plans import SaccadePlans

        self._amp_deg = float(np.rad2deg(self.amplitude))
        self._int_deg = float(np.rad2deg(self.intended_amplitude))
        nan3 = np.full(3, np.nan)
        self._batch = b = SaccadePlans(
            self.onset_ms, self.start_angles, self.end_angles, self.intended_end_angles, self.amplitude,
            self.intended_amplitude, self.signal_start_angles, nan3 if self.target is None else self.target,
            nan3 if self.intended_target is None else self.intended_target, generator=self.generator,
            vergence=self.vergence, eye_position=self.eye_position)
        self.executed_rotation = b.executed_rotation[0]
        self.efference_copy = b.efference_copy[0]
        self.efference_copy_eye = b.efference_copy_eye[0]

    @classmethod
    def from_batch(cls, plans, k: int) -> "SaccadePlan":
        """Plan ``k`` of a ``models.SaccadePlans`` batch as a single plan."""
        return cls(onset_ms=int(plans.onset_ms[k]), start_angles=plans.start[k], end_angles=plans.end[k],
                   amplitude=float(plans.amplitude[k]), generator=plans.generator, target=plans.target[k],
                   intended_target=plans.intended_target[k], intended_end_angles=plans.intended_end[k],
                   intended_amplitude=float(plans.intended_amplitude[k]), vergence=plans.vergence,
                   eye_position=plans.eye_position, signal_start_angles=plans.signal_start[k])

    # -- summary numbers -------------------------------------------------------------------
    @property
    def amplitude_deg(self) -> float:
        return self._amp_deg

    @property
    def main_sequence(self) -> MainSequence | None:
        """The legacy kinematics, when this plan uses them (else None)."""
        return self.generator if self.legacy else None

    duration_ms = _one('duration_ms', float, """Saccade duration: between the 30 deg/s crossings of the eye speed (burst generator), or onset until the speed falls below 20 deg/s (legacy main sequence).""")
    settle_ms = _one('settle_ms', float, """Time after onset at which the trajectory (vergence included) has reached its endpoint.""")
    offset_ms = _one('offset_ms', float, """Absolute time of saccade offset (the last 30 deg/s crossing; legacy: onset + duration).""")
    movement_onset_ms = _one('movement_onset_ms', float, """Absolute time the eye speed first exceeds 30 deg/s (legacy: ``onset_ms``).""")
    end_ms = _one('end_ms', int, """Absolute whole millisecond from which the eyes hold the endpoint.""")
    peak_velocity = _one('peak_velocity', float, """Cyclopean peak speed, rad/s (of the executed displacement).""")

    @property
    def burst(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The burst of the saccade generator: (absolute times ms, rate deg/ms); None for legacy."""
        if self.legacy:
            return None
        prof = self.generator.profile(self._int_deg)
        return self.onset_ms + np.arange(len(prof.burst)) * prof.dt_ms, prof.burst.copy()

    @property
    def endpoint_error_deg(self) -> np.ndarray:
        """Per eye (2,), the angle between the executed and the intended gaze direction at the end."""
        return self._batch.endpoint_error_deg[0].copy()

    # -- trajectory ------------------------------------------------------------------------
    def _at(self, t_ms, method, *args) -> np.ndarray:
        t = _times(t_ms)
        return method(t.reshape(1, -1), *args).reshape(t.shape + (2, 3))

    def profile(self, t_ms) -> tuple[np.ndarray, np.ndarray]:
        """Normalised position ``s`` and its rate ``ds/dt`` (1/ms) of the nominal plant at finite
        absolute times ``t_ms``."""
        t = _times(t_ms)
        tr = (t - self.onset_ms).reshape(1, -1)
        done = tr >= self.settle_ms
        p = self._batch.executed_profiles
        s = np.where(done, 1.0, p.position(tr, 0)).reshape(t.shape)
        return s, np.where(done, 0.0, p.rate(tr, 0)).reshape(t.shape)

    def angles(self, t_ms) -> np.ndarray:
        """Executed Fick angles at absolute times ``t_ms`` (shape ``(..., 2, 3)``): what the eyes do."""
        return self._at(t_ms, self._batch.angles)

    def intended_angles(self, t_ms) -> np.ndarray:
        """The command's Fick angles at absolute times ``t_ms`` (noise-free; the efference copy's time course)."""
        return self._at(t_ms, self._batch.angles, "intended")

    def velocities(self, t_ms) -> np.ndarray:
        """Executed angular rates (rad/ms) of the Fick angles at absolute times ``t_ms``."""
        return self._at(t_ms, self._batch.velocities)

    def eye_position_signal(self, t_ms) -> np.ndarray:
        """The extraretinal eye-position signal (Fick angles, ``(..., 2, 3)`` rad) at absolute
        times ``t_ms``: the intended trajectory smoothed and delayed (``models.eye_position_signal``),
        from ``signal_start_angles`` to ``intended_end_angles``."""
        return self._at(t_ms, self._batch.eye_position_signal, self.eye_position)

    def with_eye_position(self, eye_position) -> "SaccadePlan":
        """This plan read through another eye-position signal timing (an ``EyePositionSignal``): a copy
        that shares the validated trajectory (no re-validation, unlike ``dataclasses.replace``)."""
        from .eye_position_signal import EyePositionSignal

        if not isinstance(eye_position, EyePositionSignal):
            raise checks.InputTypeError(f"eye_position must be a models.EyePositionSignal; got {type(eye_position).__name__}")
        plan = copy.copy(self)
        plan.eye_position = eye_position
        return plan

    def sample(self, step_ms: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
        """Times (relative to onset) and planned angles from onset to settle, every ``step_ms`` (in [0.001, 1000])."""
        step_ms = checks.real("step_ms", step_ms, 0.001, 1000.0)
        t = np.arange(0.0, self.settle_ms + step_ms, step_ms)
        return t, self.angles(self.onset_ms + t)
