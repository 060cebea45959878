"""Saccade plans of one head: ``SaccadePlan``, a planned binocular saccade with its efference copy
(N = 1 of ``models.SaccadePlans``), and the trajectory models a head can use (``SACCADE_MODELS``).

Angles are radians unless a name ends in ``_deg``; times are in milliseconds (``_ms``). The
MuJoCo-free geometry (Fick angles, Listing's law, the oculomotor range, fixation) and the legacy
main sequence live in ``models.eye_kinematics``.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np

from conformal import checks

from .eye_kinematics.main_sequence import MainSequence, times
from .eye_kinematics.ranges import OculomotorRangeError, check_point
from .eye_position_signal import EyePositionSignal
from .saccade_generator import BurstGenerator
from .saccade_plans import SaccadePlans
from .vergence import VergenceDynamics

__all__ = ["SACCADE_MODELS", "SaccadePlan"]

#: Trajectory models of ``Head(saccade_model=...)``: the brainstem burst generator (default) and
#: the earlier analytic main-sequence planner.
SACCADE_MODELS = ("burst", "legacy")


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
        self.intended_amplitude = (
            self.amplitude
            if self.intended_amplitude is None
            else checks.real("intended_amplitude", self.intended_amplitude, 0.0, np.pi, hint="radians")
        )
        if self.generator is None:
            self.generator = BurstGenerator()
        if not isinstance(self.generator, (BurstGenerator, MainSequence)):
            raise checks.InputTypeError(
                f"generator must be a models.BurstGenerator or a models.MainSequence; "
                f"got {type(self.generator).__name__}"
            )
        self.legacy = isinstance(self.generator, MainSequence)
        if self.vergence is None and not self.legacy:
            self.vergence = VergenceDynamics()
        if self.vergence is not None and not isinstance(self.vergence, VergenceDynamics):
            raise checks.InputTypeError(
                f"vergence must be a models.VergenceDynamics or None; got {type(self.vergence).__name__}"
            )
        if self.eye_position is None:
            self.eye_position = EyePositionSignal()
        if not isinstance(self.eye_position, EyePositionSignal):
            raise checks.InputTypeError(
                f"eye_position must be a models.EyePositionSignal or None; got {type(self.eye_position).__name__}"
            )
        for name in ("target", "intended_target"):
            if getattr(self, name) is not None:
                setattr(self, name, check_point(getattr(self, name), name))
        self._amp_deg = float(np.rad2deg(self.amplitude))
        self._int_deg = float(np.rad2deg(self.intended_amplitude))
        nan3 = np.full(3, np.nan)
        self._batch = b = SaccadePlans(
            self.onset_ms,
            self.start_angles,
            self.end_angles,
            self.intended_end_angles,
            self.amplitude,
            self.intended_amplitude,
            self.signal_start_angles,
            nan3 if self.target is None else self.target,
            nan3 if self.intended_target is None else self.intended_target,
            generator=self.generator,
            vergence=self.vergence,
            eye_position=self.eye_position,
        )
        self.executed_rotation = b.executed_rotation[0]
        self.efference_copy = b.efference_copy[0]
        self.efference_copy_eye = b.efference_copy_eye[0]

    @classmethod
    def from_batch(cls, plans, k: int) -> SaccadePlan:
        """Plan ``k`` of a ``models.SaccadePlans`` batch as a single plan."""
        return cls(
            onset_ms=int(plans.onset_ms[k]),
            start_angles=plans.start[k],
            end_angles=plans.end[k],
            amplitude=float(plans.amplitude[k]),
            generator=plans.generator,
            target=plans.target[k],
            intended_target=plans.intended_target[k],
            intended_end_angles=plans.intended_end[k],
            intended_amplitude=float(plans.intended_amplitude[k]),
            vergence=plans.vergence,
            eye_position=plans.eye_position,
            signal_start_angles=plans.signal_start[k],
        )

    # -- summary numbers -------------------------------------------------------------------
    @property
    def amplitude_deg(self) -> float:
        return self._amp_deg

    @property
    def main_sequence(self) -> MainSequence | None:
        """The legacy kinematics, when this plan uses them (else None)."""
        if not self.legacy:
            return None
        assert isinstance(self.generator, MainSequence), "a legacy plan's generator is a MainSequence"
        return self.generator

    duration_ms = _one(
        "duration_ms",
        float,
        """Saccade duration: between the 30 deg/s crossings of the eye speed (burst generator), or onset until the speed falls below 20 deg/s (legacy main sequence).""",
    )
    settle_ms = _one(
        "settle_ms", float, """Time after onset at which the trajectory (vergence included) has reached its endpoint."""
    )
    offset_ms = _one(
        "offset_ms",
        float,
        """Absolute time of saccade offset (the last 30 deg/s crossing; legacy: onset + duration).""",
    )
    movement_onset_ms = _one(
        "movement_onset_ms", float, """Absolute time the eye speed first exceeds 30 deg/s (legacy: ``onset_ms``)."""
    )
    end_ms = _one("end_ms", int, """Absolute whole millisecond from which the eyes hold the endpoint.""")
    peak_velocity = _one("peak_velocity", float, """Cyclopean peak speed, rad/s (of the executed displacement).""")

    @property
    def burst(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The burst of the saccade generator: (absolute times ms, rate deg/ms); None for legacy."""
        if self.legacy:
            return None
        assert isinstance(self.generator, BurstGenerator), "a burst plan's generator is a BurstGenerator"
        prof = self.generator.profile(self._int_deg)
        return self.onset_ms + np.arange(len(prof.burst)) * prof.dt_ms, prof.burst.copy()

    @property
    def endpoint_error_deg(self) -> np.ndarray:
        """Per eye (2,), the angle between the executed and the intended gaze direction at the end."""
        return self._batch.endpoint_error_deg[0].copy()

    # -- trajectory ------------------------------------------------------------------------
    def _at(self, t_ms, method, *args) -> np.ndarray:
        t = times(t_ms)
        return method(t.reshape(1, -1), *args).reshape(t.shape + (2, 3))

    def profile(self, t_ms) -> tuple[np.ndarray, np.ndarray]:
        """Normalised position ``s`` and its rate ``ds/dt`` (1/ms) of the nominal plant at finite
        absolute times ``t_ms``."""
        t = times(t_ms)
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

    def with_eye_position(self, eye_position) -> SaccadePlan:
        """This plan read through another eye-position signal timing (an ``EyePositionSignal``): a copy
        that shares the validated trajectory (no re-validation, unlike ``dataclasses.replace``)."""
        if not isinstance(eye_position, EyePositionSignal):
            raise checks.InputTypeError(
                f"eye_position must be a models.EyePositionSignal; got {type(eye_position).__name__}"
            )
        plan = copy.copy(self)
        plan.eye_position = eye_position
        return plan

    def sample(self, step_ms: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
        """Times (relative to onset) and planned angles from onset to settle, every ``step_ms`` (in [0.001, 1000])."""
        step_ms = checks.real("step_ms", step_ms, 0.001, 1000.0)
        t = np.arange(0.0, self.settle_ms + step_ms, step_ms)
        return t, self.angles(self.onset_ms + t)
