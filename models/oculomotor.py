"""Oculomotor plant: binocular fixation geometry, Listing's law and main-sequence saccades.

Pure numpy (no MuJoCo).  Angles are radians unless a name ends in ``_deg``; times are in
milliseconds (``_ms``).

Head frame: x forward (primary gaze direction), y to the head's left, z up.  Eye orientation is
given as Fick angles ``(h, v, t)`` -- the gimbal of ``models/head.xml``::

    R = rot(-z, h) @ rot(-y, v) @ rot(+x, t)

``h > 0`` turns the gaze to the right, ``v > 0`` up, ``t > 0`` turns the top of the eye to the
subject's right.  ``R`` maps eye coordinates at primary position to head coordinates; the eye
frame of DESIGN.md is ``x2 = R[:, 0]`` (optical axis), ``x3 = -R[:, 1]`` (right),
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

from dataclasses import dataclass, field

import numpy as np

from conformal import checks

__all__ = [
    "H_RANGE",
    "V_RANGE",
    "T_RANGE",
    "MAX_PEAK_VELOCITY",
    "MainSequence",
    "OculomotorRangeError",
    "SaccadePlan",
    "fick_matrix",
    "fick_angles",
    "listing_torsion",
    "gaze_direction",
    "rotation_vector",
    "fixation_angles",
    "eye_frame_basis",
]

H_RANGE = np.deg2rad(45.0)  #: horizontal oculomotor range (+-), radians
V_RANGE = np.deg2rad(35.0)  #: vertical oculomotor range (+-), radians
T_RANGE = np.deg2rad(20.0)  #: Fick-torsion joint range (+-); Listing torsion stays below 15 deg
MAX_PEAK_VELOCITY = np.deg2rad(700.0)  #: physiological ceiling of eye speed, rad/s
MIN_TARGET_DISTANCE = 0.05  #: metres from an eye's rotation centre

_X = np.array([1.0, 0.0, 0.0])
_Y = np.array([0.0, 1.0, 0.0])
_Z = np.array([0.0, 0.0, 1.0])

#: Columns are the head-frame directions of the DESIGN.md eye axes (x1, x2, x3) at primary position.
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
    h, v = _angles(h=h, v=v)
    return 2.0 * np.arctan(np.tan(h / 2) * np.tan(v / 2))


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
    d = p[None, :] - c
    dist = np.linalg.norm(d, axis=1)
    if np.any(dist < MIN_TARGET_DISTANCE):
        raise OculomotorRangeError(
            f"target {p.tolist()} is closer than {MIN_TARGET_DISTANCE} m to an eye; choose a farther point"
        )
    h = np.arctan2(-d[:, 1], d[:, 0])
    v = np.arctan2(d[:, 2], np.hypot(d[:, 0], d[:, 1]))
    if np.any(np.abs(h) > H_RANGE + 1e-9) or np.any(np.abs(v) > V_RANGE + 1e-9):
        raise OculomotorRangeError(
            "target outside the oculomotor range (+-45 deg horizontal, +-35 deg vertical): "
            f"needs h = {np.rad2deg(h).round(1).tolist()} deg, v = {np.rad2deg(v).round(1).tolist()} deg "
            "(left, right eye); move the target or turn the neck"
        )
    return np.column_stack([h, v, listing_torsion(h, v)])


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

    @staticmethod
    def _times(t_ms) -> np.ndarray:
        return checks.array("t_ms", t_ms, kinds="biuf").astype(float)

    def _A(self, amp_deg):
        return 1.0 / -np.expm1(-np.asarray(amp_deg, float) / self.m0_deg)

    def position_deg(self, t_ms, amp_deg: float) -> np.ndarray:
        """E(t) in degrees for ``t_ms`` after onset (0 before onset)."""
        t = np.maximum(self._times(t_ms), 0.0)
        amp_deg = self._amp(amp_deg)
        if amp_deg <= 0:
            return np.zeros_like(t)
        m0, v, A = self.m0_deg, self.vpk_deg_per_ms, self._A(amp_deg)
        x = (v * t - amp_deg) / m0
        # m0 * [ln A + v t/m0 - ln(1 + A e^x)], written stably
        return m0 * (np.log(A) + v * t / m0 - np.logaddexp(0.0, np.log(A) + x))

    def velocity_deg_per_ms(self, t_ms, amp_deg: float) -> np.ndarray:
        """dE/dt in deg/ms (0 up to and including onset; jumps to the peak just after it)."""
        t = self._times(t_ms)
        amp_deg = self._amp(amp_deg)
        if amp_deg <= 0:
            return np.zeros_like(t)
        A = self._A(amp_deg)
        x = (self.vpk_deg_per_ms * np.maximum(t, 0.0) - amp_deg) / self.m0_deg
        vel = self.vpk_deg_per_ms / (1.0 + A * np.exp(x))
        return np.where(t > 0, vel, 0.0)

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


@dataclass
class SaccadePlan:
    """A planned binocular saccade, with its efference copy, before the eyes move.

    Times are simulation milliseconds; ``onset_ms`` is absolute. Angles are Fick ``(h, v, t)``
    per eye, shape ``(2, 3)`` ordered (left, right). Both eyes share the normalised main-sequence
    profile ``s(t) = E(t; T)/T`` of the cyclopean amplitude ``T``; ``h, v`` move along
    ``a0 + s (a1 - a0)`` and torsion follows Listing's law at every instant.

    ``efference_copy[e]`` is the planned rotation of eye ``e`` in the head frame, from pre- to
    post-saccadic orientation (``R_post @ R_pre.T``); ``efference_copy_eye[e]`` is the same
    rotation in the pre-saccadic eye frame with axes ordered (x1 up, x2 optical axis, x3 right)
    of DESIGN.md. The image of a world-fixed point moves by the inverse rotation.
    """

    onset_ms: int
    start_angles: np.ndarray
    end_angles: np.ndarray
    amplitude: float  #: cyclopean amplitude, radians
    main_sequence: MainSequence = field(default_factory=MainSequence)
    target: np.ndarray | None = None  #: executed (possibly noisy) world fixation point
    intended_target: np.ndarray | None = None  #: world point asked for, before endpoint noise

    def __post_init__(self):
        self.onset_ms = checks.integer("onset_ms", self.onset_ms, 0, None, hint="a whole millisecond")
        for name in ("start_angles", "end_angles"):
            a = checks.array(name, getattr(self, name), kinds="biuf", finite=False)
            if a.shape != (2, 3):
                raise ValueError(f"{name} must be Fick angles of shape (2, 3) [eye, (h, v, t)]; got {a.shape}")
            if not np.all(np.isfinite(a)):
                raise OculomotorRangeError("saccade plan angles must be finite")
            setattr(self, name, a.astype(float))
        self.amplitude = checks.real("amplitude", self.amplitude, 0.0, np.pi, hint="radians")
        if not isinstance(self.main_sequence, MainSequence):
            raise checks.InputTypeError(f"main_sequence must be a MainSequence; got {type(self.main_sequence).__name__}")
        for name in ("target", "intended_target"):
            if getattr(self, name) is not None:
                setattr(self, name, _check_point(getattr(self, name), name))
        self._amp_deg = float(np.rad2deg(self.amplitude))
        R0 = fick_matrix(self.start_angles[:, 0], self.start_angles[:, 1], self.start_angles[:, 2])
        R1 = fick_matrix(self.end_angles[:, 0], self.end_angles[:, 1], self.end_angles[:, 2])
        self.efference_copy = R1 @ np.swapaxes(R0, -1, -2)
        B = PRIMARY_EYE_BASIS
        self.efference_copy_eye = B.T @ np.swapaxes(R0, -1, -2) @ R1 @ B

    # -- summary numbers -------------------------------------------------------------------
    @property
    def amplitude_deg(self) -> float:
        return self._amp_deg

    @property
    def duration_ms(self) -> float:
        """Main-sequence duration (onset until speed < 20 deg/s)."""
        return self.main_sequence.duration_ms(self._amp_deg)

    @property
    def settle_ms(self) -> float:
        """Time after onset at which the trajectory has reached its endpoint (held afterwards)."""
        return self.main_sequence.settle_ms(self._amp_deg)

    @property
    def offset_ms(self) -> float:
        """Absolute time of saccade offset (onset + duration)."""
        return self.onset_ms + self.duration_ms

    @property
    def end_ms(self) -> int:
        """Absolute whole millisecond from which the eyes hold the endpoint."""
        return int(self.onset_ms + np.ceil(self.settle_ms))

    @property
    def peak_velocity(self) -> float:
        """Cyclopean peak speed, rad/s."""
        return float(np.deg2rad(self.main_sequence.peak_velocity_deg_s(self._amp_deg)))

    # -- trajectory ------------------------------------------------------------------------
    def profile(self, t_ms) -> tuple[np.ndarray, np.ndarray]:
        """Normalised position ``s`` and its rate ``ds/dt`` (1/ms) at finite absolute times ``t_ms``."""
        tr = MainSequence._times(t_ms) - self.onset_ms
        if self._amp_deg <= 0:
            return (tr >= 0).astype(float), np.zeros_like(tr)
        s = self.main_sequence.position_deg(tr, self._amp_deg) / self._amp_deg
        ds = self.main_sequence.velocity_deg_per_ms(tr, self._amp_deg) / self._amp_deg
        done = tr >= self.settle_ms
        return np.where(done, 1.0, s), np.where(done, 0.0, ds)

    def angles(self, t_ms) -> np.ndarray:
        """Planned Fick angles at absolute times ``t_ms`` (shape ``(..., 2, 3)``)."""
        s, _ = self.profile(t_ms)
        hv = self.start_angles[:, :2] + s[..., None, None] * (self.end_angles[:, :2] - self.start_angles[:, :2])
        return np.concatenate([hv, listing_torsion(hv[..., 0], hv[..., 1])[..., None]], axis=-1)

    def velocities(self, t_ms) -> np.ndarray:
        """Planned angular rates (rad/ms) of the Fick angles at absolute times ``t_ms``."""
        s, ds = self.profile(t_ms)
        dhv = ds[..., None, None] * (self.end_angles[:, :2] - self.start_angles[:, :2])
        hv = self.start_angles[:, :2] + s[..., None, None] * (self.end_angles[:, :2] - self.start_angles[:, :2])
        h, v = hv[..., 0], hv[..., 1]
        th, tv = np.tan(h / 2), np.tan(v / 2)
        # d/dt 2 atan(th tv) = 2/(1+(th tv)^2) * (0.5 sec^2(h/2) tv h' + 0.5 th sec^2(v/2) v')
        dt = (1.0 / (1.0 + (th * tv) ** 2)) * (
            (1 + th**2) * tv * dhv[..., 0] + th * (1 + tv**2) * dhv[..., 1]
        )
        return np.concatenate([dhv, dt[..., None]], axis=-1)

    def sample(self, step_ms: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
        """Times (relative to onset) and planned angles from onset to settle, every ``step_ms`` (in [0.001, 1000])."""
        step_ms = checks.real("step_ms", step_ms, 0.001, 1000.0)
        t = np.arange(0.0, self.settle_ms + step_ms, step_ms)
        return t, self.angles(self.onset_ms + t)
