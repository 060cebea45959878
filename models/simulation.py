"""``Head``: the binocular head simulation (MjModel/MjData, eye renderer, saccade plant).

Time advances in whole milliseconds (``step_ms``). The eyes follow their commands through the
servo of :mod:`models.servo` (two physics timesteps: ``Head(timestep_ms=...,
saccade_timestep_ms=...)``, both must divide 1 ms); scene objects, flashes and visibility are
:mod:`models.scene_objects`'s; renders with an exposure :mod:`models.exposure`'s.

Measured (dots scene, one core): 300 ms of fixation ~1.2 ms; a 10 deg saccade (~83 ms to its
settled end with the burst generator) + 250 ms of fixation ~2.2 ms (``benchmarks/render.py`` prints current numbers).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, fields
from typing import Any, Literal, overload

import numpy as np

from conformal import checks

from ._gl import mujoco
from .build import DEFAULT_FOVY_DEG, DEFAULT_IPD, build_spec
from .eye_kinematics import (
    MainSequence,
    MotorNoise,
    OculomotorRangeError,
    check_point,
    cyclopean_amplitude,
    displaced,
    fixation_angles,
    noisy_endpoints,
)
from .eye_position_signal import EyePositionSignal
from .head_rendering import HeadRendering
from .oculomotor import SACCADE_MODELS, SaccadePlan
from .oculomotor_state import OculomotorState
from .plant import EYE_DRIVES, OrbitalPlant
from .render import EYES, MAX_IMAGE_SIDE, EyeRenderer, focal_pixels
from .saccade_generator import BurstGenerator
from .scene_objects import SceneObjects
from .scenes import SCENES, SceneInfo
from .servo import DEFAULT_SACCADE_TIMESTEP_MS, DEFAULT_TIMESTEP_MS, EyeServo, _ms, _substeps
from .vergence import VergenceDynamics

__all__ = ["Head", "EyeState", "EyeTrace"]

_JOINTS = tuple(f"{side}_eye_{a}" for side in ("left", "right") for a in "hvt")
# camera frame (x right, y up, z back) -> the README's eye axes (x1 up, x2 optical axis, x3 right)
_CAM_TO_EYE = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


@dataclass(frozen=True)
class EyeState:
    """One eye at one instant. ``angles`` = Fick (h, v, t) in radians (h > 0 right, v > 0 up,
    see :mod:`models.eye_kinematics.fick`); ``eye_axes`` columns are the world directions of x1 (up),
    x2 (optical axis), x3 (right)."""

    name: str
    angles: np.ndarray
    camera_position: np.ndarray
    camera_xmat: np.ndarray
    eye_axes: np.ndarray

    def project(self, points) -> np.ndarray:
        """Image-plane points ``z = (x3 + i x1)/x2`` of finite world ``points`` (N, 3) or (3,)
        (NaN for points behind the eye)."""
        d = _world_points(points) - self.camera_position
        x = d @ self.eye_axes  # columns x1, x2, x3
        with np.errstate(divide="ignore", invalid="ignore"):
            z = (x[:, 2] + 1j * x[:, 0]) / x[:, 1]
        return np.where(x[:, 1] > 0, z, np.nan + 1j * np.nan)


@dataclass(frozen=True)
class EyeTrace:
    """Eye joint angles/velocities sampled at every physics step (``times_ms`` absolute), beside
    the executed command the servo tracks, the intended command (the efference copy's time course)
    and the eye-position signal at the same instants."""

    times_ms: np.ndarray  #: (K,)
    angles: np.ndarray  #: (K, 2, 3) measured Fick angles, radians
    velocities: np.ndarray  #: (K, 2, 3) measured joint rates, rad/s
    planned: np.ndarray  #: (K, 2, 3) executed (noisy) command at the same instants
    intended: np.ndarray | None = None  #: (K, 2, 3) intended command (noise-free)
    eye_position_signal: np.ndarray | None = None  #: (K, 2, 3) the brain's estimate of eye orientation

    @classmethod
    def concatenate(cls, traces: list[EyeTrace]) -> EyeTrace:
        """Consecutive pieces (e.g. one per :meth:`Head.step_ms` call) as one trace; a field that the
        first piece lacks (``None``) stays ``None``."""
        traces = list(traces)
        if not traces or not all(isinstance(t, EyeTrace) for t in traces):
            raise ValueError("concatenate needs a non-empty list of EyeTrace pieces")
        names = [f.name for f in fields(cls)]
        have = {n: [getattr(t, n) is not None for t in traces] for n in names}
        mixed = [n for n in names if any(have[n]) and not all(have[n])]
        if mixed:
            raise ValueError(
                f"the pieces disagree on which fields they hold ({', '.join(mixed)}): "
                "concatenate traces of one simulation"
            )
        joined: dict[str, Any] = {
            n: np.concatenate([getattr(t, n) for t in traces]) if have[n][0] else None for n in names
        }
        return cls(**joined)


def _world_points(points) -> np.ndarray:
    """Finite world points as an (N, 3) float array (a single (3,) point gives N = 1)."""
    p = checks.array("points", points, kinds="biuf", ndim=(1, 2)).astype(float)
    p = np.atleast_2d(p)
    if p.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3) or (3,) (x, y, z in metres); got {np.shape(points)}")
    return p


def _angle(name: str, value) -> float:
    """A finite angle (radians); NaN or infinity is an :class:`OculomotorRangeError` (a ``ValueError``)."""
    try:
        return checks.real(name, value, hint="radians")
    except checks.InputTypeError:
        raise
    except ValueError as exc:
        raise OculomotorRangeError(str(exc)) from None


def _seed(seed) -> int | None:
    return None if seed is None else checks.integer("seed", seed, 0, None, hint="or None")


class Head(SceneObjects, HeadRendering):
    """The binocular head in a scene.

    Args:
        scene: one of ``models.SCENES`` (``"bar"``, ``"dots"``, ``"natural"``, ``"search"``).
        image_size: eye image size, ``int`` (square) or ``(height, width)``, each in [1, 4096].
        fovy_deg, ipd: each eye's vertical field of view (default 70 deg); interpupillary distance (m).
        quality: ``"fast"`` (default: no shadows/multisampling) or ``"default"`` (MuJoCo's).
        seed: seeds scene layouts (``search``) and saccade endpoint noise (an integer >= 0 or None).
        endpoint_noise: s.d. of saccade endpoint error as a fraction of amplitude (0-1; human: 5-10 %,
            Kowler & Blaser 1995, Vision Res 35:1741); downstream of the generator.
        motor_noise: a :class:`models.MotorNoise` instead of ``endpoint_noise`` (default none).
        linear_tail: take the eyes' slow stretches (settle tails, long holds) in closed form
            (:mod:`models.linear_tail`, within 1e-4 deg of stepping); False steps every physics step.
        saccade_model: ``"burst"`` (default: :mod:`models.saccade_generator`) or ``"legacy"``.
        main_sequence: kinematics of the legacy model (defaults: Van Wetter & Van Opstal 2008).
        generator, vergence, eye_position: the burst generator's, vergence's and eye-position
            signal's parameters (defaults ``BurstGenerator()``, ``VergenceDynamics()``, ``EyePositionSignal()``).
        timestep_ms, saccade_timestep_ms: physics timesteps outside saccades (1 ms) and during them
            (0.25 ms); each must divide 1 ms and be at least 0.01 ms.
        eye_drive: ``"plant"`` (default: torques through the orbital plant, :mod:`models.plant`) or
            ``"servo"`` (a stiff position servo: exact, noise-free pointing).
        plant: the plant's time constants and the brain's pulse (default ``OrbitalPlant()``).

    Times given to its methods are whole milliseconds, at most ``MAX_STEP_MS`` (60,000) per call.
    Each argument in full, and a head in use: docs/head.md ("Head and oculomotor").
    """

    def __init__(
        self,
        scene: str = "dots",
        image_size: int | tuple[int, int] = 128,
        *,
        fovy_deg: float = DEFAULT_FOVY_DEG,
        ipd: float = DEFAULT_IPD,
        quality: str = "fast",
        seed: int | None = None,
        endpoint_noise: float = 0.0,
        saccade_model: str = "burst",
        main_sequence: MainSequence | None = None,
        generator: BurstGenerator | None = None,
        vergence: VergenceDynamics | None = None,
        eye_position: EyePositionSignal | None = None,
        timestep_ms: float = DEFAULT_TIMESTEP_MS,
        saccade_timestep_ms: float = DEFAULT_SACCADE_TIMESTEP_MS,
        eye_drive: str = "plant",
        plant: OrbitalPlant | None = None,
        motor_noise: MotorNoise | None = None,
        linear_tail: bool = True,
    ):
        if not isinstance(scene, str):
            raise checks.InputTypeError(f"scene must be one of {', '.join(SCENES)}; got {scene!r}")
        self._k_fix = _substeps(timestep_ms, "timestep_ms")
        self._k_sac = _substeps(saccade_timestep_ms, "saccade_timestep_ms")
        self._renderer: EyeRenderer | None = None
        self._frame_memo_mb = 0.0  # HeadRendering.remember_frames
        if isinstance(image_size, (tuple, list)):
            if len(image_size) != 2:
                raise ValueError(f"image_size must be an int or a (height, width) pair; got {image_size!r}")
            h, w = (checks.integer(f"image_size[{i}]", v, 1, MAX_IMAGE_SIDE) for i, v in enumerate(image_size))
        else:
            h = w = checks.integer("image_size", image_size, 1, MAX_IMAGE_SIDE, hint="or a (height, width) pair")
        self.image_shape = (h, w)
        self.endpoint_noise = checks.real(
            "endpoint_noise",
            endpoint_noise,
            0.0,
            1.0,
            hint="the s.d. of the endpoint error as a fraction of the amplitude",
        )
        if motor_noise is not None and not isinstance(motor_noise, MotorNoise):
            raise checks.InputTypeError(
                f"motor_noise must be a models.MotorNoise or None; got {type(motor_noise).__name__}"
            )
        if motor_noise is not None and self.endpoint_noise > 0:
            raise ValueError("give endpoint_noise (isotropic) or motor_noise, not both")
        #: the saccadic motor error both engines draw (``models.MotorNoise``)
        self.motor_noise = motor_noise if motor_noise is not None else MotorNoise.of(self.endpoint_noise)
        self.saccade_model = checks.choice("saccade_model", saccade_model, SACCADE_MODELS)
        self.eye_drive = checks.choice("eye_drive", eye_drive, EYE_DRIVES)
        if plant is not None and self.eye_drive != "plant":
            raise ValueError("plant configures eye_drive='plant'; the servo has no plant parameters")
        for name, value, kind in (
            ("main_sequence", main_sequence, MainSequence),
            ("generator", generator, BurstGenerator),
            ("plant", plant, OrbitalPlant),
            ("vergence", vergence, VergenceDynamics),
            ("eye_position", eye_position, EyePositionSignal),
        ):
            if value is not None and not isinstance(value, kind):
                raise checks.InputTypeError(
                    f"{name} must be a models.{kind.__name__} or None; got {type(value).__name__}"
                )
        if self.saccade_model == "legacy" and (generator is not None or vergence is not None):
            raise ValueError(
                "generator and vergence configure saccade_model='burst'; the legacy model takes main_sequence"
            )
        if self.saccade_model == "burst" and main_sequence is not None:
            raise ValueError(
                "main_sequence configures saccade_model='legacy'; the burst model takes generator=BurstGenerator(...)"
            )
        seed = _seed(seed)
        self.main_sequence = main_sequence or MainSequence()
        self.generator = generator or BurstGenerator()
        self.vergence = None if self.saccade_model == "legacy" else (vergence or VergenceDynamics())
        self.eye_position = eye_position or EyePositionSignal()
        self.spec, info = build_spec(
            scene,
            ipd=ipd,
            fovy_deg=fovy_deg,
            quality=quality,
            offscreen_size=(self.image_shape[1], self.image_shape[0]),
        )
        assert info is not None, "build_spec gives the SceneInfo of a named scene"
        self.scene: SceneInfo = info
        self.spec.option.timestep = 1e-3 / self._k_fix
        self.model: mujoco.MjModel = self.spec.compile()
        self.data = mujoco.MjData(self.model)
        m = self.model
        jid = [m.joint(n).id for n in _JOINTS]
        self._qadr = np.array([m.jnt_qposadr[j] for j in jid])
        self._vadr = np.array([m.jnt_dofadr[j] for j in jid])
        self._pos_act = np.array([m.actuator(f"{n}_pos").id for n in _JOINTS])
        self._vel_act = np.array([m.actuator(f"{n}_vel").id for n in _JOINTS])
        self._ff_act = np.array([m.actuator(f"{n}_ff").id for n in _JOINTS])
        eye_ctrl = np.concatenate([self._pos_act, self._vel_act, self._ff_act])
        contiguous = np.array_equal(eye_ctrl, np.arange(eye_ctrl[0], eye_ctrl[0] + 18))
        self._eye_ctrl = slice(int(eye_ctrl[0]), int(eye_ctrl[0]) + 18) if contiguous else eye_ctrl
        self.plant = None
        command = None
        if self.eye_drive == "plant":
            self.plant = plant or OrbitalPlant()
            command = self.plant.install(
                m, self._vadr, np.array(jid), np.concatenate([self._pos_act, self._vel_act]), self.generator.plant_t2_ms
            )
        #: the command's model of the plant: (inertia, stiffness, damping), each (6, 6); None for the servo
        self.plant_command = command
        self._servo = EyeServo(m, self.data, self._k_fix, self._k_sac, self._qadr, self._vadr, self._eye_ctrl, command)
        if not checks.flag("linear_tail", linear_tail):
            self._servo.linear = None
        self._neck_act = np.array([m.actuator("neck_pan_pos").id, m.actuator("neck_tilt_pos").id])
        self._head_body = m.body("head").id
        self._eye_centres_head = np.array([m.body_pos[m.body(f"{s}_eyeball").id] for s in ("left", "right")])
        self._cam_ids = [m.camera(e).id for e in EYES]
        self._flash_gids = np.array([m.geom(name).id for name in self.scene.flashes], np.intp)
        self._seed = seed
        self.reset(seed=seed)

    # ------------------------------------------------------------------ lifecycle
    def reset(
        self, seed: int | None = None, fixate: str | Sequence[float] | np.ndarray | None = None, settle_ms: int = 10
    ) -> None:
        """Reset physics and time to 0, hide flashes, re-draw the scene layout and fixate ``fixate`` (an
        object name or world point; default: the scene's fixation).

        ``seed`` restarts the head's random stream (scene layouts, endpoint noise) from that seed; without
        one the stream continues, so each trial draws its own layout and motor noise (as gymnasium's
        ``reset`` does). The head's first reset, in its constructor, starts the stream from its ``seed``."""
        seed = _seed(seed)
        settle_ms = _ms("settle_ms", settle_ms)
        target = self.scene.default_fixation if fixate is None else fixate
        self._resolve(target)  # a bad name or point raises before anything changes
        if seed is not None or getattr(self, "_rng", None) is None:  # a seed restarts the stream; none continues it
            self._seed = self._seed if seed is None else seed
            self._rng = np.random.default_rng(self._seed)
        mujoco.mj_resetData(self.model, self.data)
        self.time_ms = 0
        self._plan: SaccadePlan | None = None
        self._servo.forget()
        self.last_plan: SaccadePlan | None = None
        self._signal_plan: SaccadePlan | None = None  # the plan the eye-position signal follows
        self._signal_memo: tuple | None = None  # (plan, its EyePositionSignal, t_ms, signal): _signal_hold_at
        self._flash_off: dict[int, int] = {}
        for gid, alpha in getattr(self, "_alpha0", {}).items():  # undo set_visible
            self.model.geom_rgba[gid, 3] = alpha
        self._alpha0: dict[int, float] = {}
        for name in self.scene.flashes:
            self.model.geom_rgba[self.model.geom(name).id, 3] = 0.0
        if self.scene.layout is not None:
            for name, pos in self.scene.layout(self._rng).items():
                self._set_mocap(name, pos)
        mujoco.mj_forward(self.model, self.data)
        self.set_gaze(target, settle_ms=settle_ms)

    def close(self) -> None:
        """Release the GL context (the simulation itself stays usable)."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __enter__(self) -> Head:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __reduce_ex__(self, protocol):
        # pickle and copy (deep or shallow) come here first: refuse before a half-built copy of the GL
        # renderer (whose __del__ would print a traceback) or a second head sharing this MjData is made
        raise TypeError(
            "a models.Head cannot be pickled or copied (pickle, copy.deepcopy, copy.copy): it holds a "
            "compiled MuJoCo model (its MjSpec) and an OpenGL context. Make a new Head with the same "
            "arguments instead; for the same state, reset it with the same seed and repeat the calls"
        )

    # ------------------------------------------------------------------ state
    def get_state(self) -> OculomotorState:
        """The oculomotor state (:class:`OculomotorState`: clock, holds, fixation, plans, random
        stream, shown objects); with ``data`` (MuJoCo's joints and set-points) all that a later
        :meth:`set_state` needs to continue from here."""
        m = self.model
        return OculomotorState(
            time_ms=self.time_ms,
            hold=self._hold.copy(),
            signal_hold=self._signal_hold.copy(),
            fixation_head=self._fix_head.copy(),
            rng=self._rng,
            seed=self._seed,
            plan=self._plan,
            signal_plan=self._signal_plan,
            last_plan=self.last_plan,
            flashes={m.geom(g).name: off for g, off in self._flash_off.items()},
            opacity={m.geom(g).name: float(m.geom_rgba[g, 3]) for g in self._alpha0},
        )

    def set_state(self, state: OculomotorState) -> None:
        """Make ``state`` this head's oculomotor state (the physics in ``data`` is left as it is; call
        ``mujoco.mj_forward`` after changing it). Objects not in ``state.opacity`` get the scene's own
        visibility back, flashes not in ``state.flashes`` are hidden."""
        if not isinstance(state, OculomotorState):
            raise checks.InputTypeError(
                f"state must be a models.OculomotorState (from Head.get_state); got {type(state).__name__}"
            )
        m = self.model
        for gid, alpha in self._alpha0.items():  # the scene's own visibility, then the state's
            m.geom_rgba[gid, 3] = alpha
        self._alpha0 = {}
        for name, alpha in state.opacity.items():
            gid = self._geom_id(name)
            self._alpha0[gid] = float(m.geom_rgba[gid, 3])
            m.geom_rgba[gid, 3] = alpha
        m.geom_rgba[self._flash_gids, 3] = 0.0
        self._flash_off = {}
        for name, off in state.flashes.items():
            gid = m.geom(name).id
            m.geom_rgba[gid, 3] = 1.0
            self._flash_off[gid] = int(off)
        self.time_ms = int(state.time_ms)
        self._hold = np.array(state.hold, float).reshape(2, 3)
        self._signal_hold = np.array(state.signal_hold, float).reshape(2, 3)
        self._fix_head = np.array(state.fixation_head, float).reshape(3)
        self._rng, self._seed = state.rng, state.seed
        self._plan, self._signal_plan, self.last_plan = state.plan, state.signal_plan, state.last_plan
        self._servo.forget()

    #: MuJoCo arrays that place the scene's bodies and show its geoms (:meth:`scene_state`)
    SCENE_STATE = ("qpos", "mocap_pos", "mocap_quat", "geom_rgba")

    def scene_state(self) -> dict[str, np.ndarray]:
        """Copies of the MuJoCo arrays that place the scene's bodies and show its geoms (a 3-D
        replay's pose): ``qpos``, ``mocap_pos``, ``mocap_quat`` (``data``) and ``geom_rgba`` (``model``)."""
        return {k: getattr(self.model if k == "geom_rgba" else self.data, k).copy() for k in self.SCENE_STATE}

    def set_scene_state(self, state: dict) -> None:
        """Pose the scene as :meth:`scene_state` returned it (positions and colours only: no simulation,
        no oculomotor state), then ``mj_forward``. ``ValueError`` for a missing array, another shape
        or a value that is not finite."""
        if not isinstance(state, dict):
            raise checks.InputTypeError(f"state must be a dict from Head.scene_state; got {type(state).__name__}")
        new = {}
        for k in self.SCENE_STATE:
            now = getattr(self.model if k == "geom_rgba" else self.data, k)
            if k not in state:
                raise ValueError(f"the scene state lacks {k!r} (it needs {', '.join(self.SCENE_STATE)})")
            try:
                new[k] = np.asarray(state[k], dtype=float)
            except (TypeError, ValueError):
                raise ValueError(f"the scene state's {k} is not an array of numbers") from None
            if new[k].shape != now.shape:
                raise ValueError(f"the scene state's {k} has shape {new[k].shape}; this scene's is {now.shape}")
            if not np.isfinite(new[k]).all():
                raise ValueError(f"the scene state's {k} holds a value that is not finite")
        for k, v in new.items():
            getattr(self.model if k == "geom_rgba" else self.data, k)[:] = v
        mujoco.mj_forward(self.model, self.data)

    @property
    def eye_joint_addresses(self) -> tuple[np.ndarray, np.ndarray]:
        """Where the six eye joints (left h, v, t, right h, v, t) sit in ``data.qpos`` and ``data.qvel``."""
        return self._qadr.copy(), self._vadr.copy()

    @property
    def eye_actuator_ids(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The eye joints' actuator ids in ``data.ctrl``: position servo, velocity set-point and torque
        feed-forward, six each (joints ordered as :attr:`eye_joint_addresses`)."""
        return self._pos_act.copy(), self._vel_act.copy(), self._ff_act.copy()

    # ------------------------------------------------------------------ geometry
    def head_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World position (3,) and orientation (3, 3) of the head body now."""
        return self.data.xpos[self._head_body].copy(), self.data.xmat[self._head_body].reshape(3, 3).copy()

    def to_head(self, point) -> np.ndarray:
        """World point -> head frame (x forward, y left, z up; origin at the head body)."""
        x, R = self.head_pose()
        return R.T @ (check_point(point) - x)

    def to_world(self, point_head) -> np.ndarray:
        """Head-frame point (a finite 3-vector) -> world."""
        x, R = self.head_pose()
        return x + R @ check_point(point_head, "point_head")

    @property
    def eye_centres_head(self) -> np.ndarray:
        """Head-frame rotation centres (2, 3) of the (left, right) eyes, metres."""
        return self._eye_centres_head.copy()

    @property
    def cyclopean_position(self) -> np.ndarray:
        """World position of the cyclopean eye (midway between the eyes' rotation centres)."""
        return self.to_world(self._eye_centres_head.mean(axis=0))

    def _resolve(self, target) -> np.ndarray:
        if isinstance(target, str):
            return self.object_position(target)
        return check_point(target)

    def fixation_angles(self, point) -> np.ndarray:
        """Fick angles (2, 3) [left, right] fixating world ``point`` (Listing torsion)."""
        return fixation_angles(self.to_head(point), self._eye_centres_head)

    # ------------------------------------------------------------------ eye state
    @property
    def eye_angles(self) -> np.ndarray:
        """Measured Fick angles (2, 3) [eye, (h, v, t)], radians."""
        return self.data.qpos[self._qadr].reshape(2, 3).copy()

    @property
    def commanded_angles(self) -> np.ndarray:
        """Planned Fick angles (2, 3) at the current time (what the servo is tracking)."""
        return self._command_at(np.array([float(self.time_ms)]))[0]

    def eye_states(self) -> tuple[EyeState, EyeState]:
        """(left, right) :class:`EyeState` from the simulation's current kinematics."""
        q = self.eye_angles
        out = []
        for i, (eye, cid) in enumerate(zip(EYES, self._cam_ids)):
            xmat = self.data.cam_xmat[cid].reshape(3, 3).copy()
            out.append(EyeState(eye, q[i], self.data.cam_xpos[cid].copy(), xmat, xmat @ _CAM_TO_EYE))
        return out[0], out[1]

    def project(self, points) -> np.ndarray:
        """Image-plane points z (complex), shape (2, N) [left, right], of world ``points``."""
        return np.stack([s.project(points) for s in self.eye_states()])

    def project_to_pixels(self, points) -> np.ndarray:
        """Pixel (row, col) positions (2, N, 2) of world ``points`` in this head's eye images."""
        z = self.project(points)
        h, w = self.image_shape
        f = self.pixels_per_unit
        return np.stack([(h - 1) / 2 - z.imag * f, (w - 1) / 2 + z.real * f], axis=-1)

    @property
    def pixels_per_unit(self) -> float:
        """f_px of the eye images (same for both eyes)."""
        return focal_pixels(self.image_shape[0], np.deg2rad(self.model.cam_fovy[self._cam_ids[0]]))

    # ------------------------------------------------------------------ gaze & saccades
    def set_gaze(self, target, settle_ms: int = 10) -> np.ndarray:
        """Instantly fixate ``target`` (object name or world point): set joints and servo
        set-points, then let the physics settle for ``settle_ms``. Returns the Fick angles."""
        settle_ms = _ms("settle_ms", settle_ms)
        p = self._resolve(target)
        ang = self.fixation_angles(p)
        self._plan = None
        self._signal_plan = None
        self._hold = ang
        self._signal_hold = ang.copy()
        self._fix_head = self.to_head(p)
        self.data.qpos[self._qadr] = ang.ravel()
        self.data.qvel[self._vadr] = 0.0
        self.data.ctrl[self._eye_ctrl] = self._servo.hold_controls(ang)
        mujoco.mj_forward(self.model, self.data)
        if settle_ms:
            self.step_ms(settle_ms)
        return ang

    def set_neck(self, pan: float, tilt: float) -> None:
        """Neck pan (> 0 left) / tilt (> 0 up) servo set-points, radians (the head then moves)."""
        pan, tilt = _angle("pan", pan), _angle("tilt", tilt)
        for v, aid in zip((pan, tilt), self._neck_act):
            lo, hi = self.model.actuator_ctrlrange[aid]
            if not lo <= v <= hi:
                raise OculomotorRangeError(f"neck angle {v} outside [{lo:.3f}, {hi:.3f}] rad")
        self.data.ctrl[self._neck_act] = [pan, tilt]

    def plan_saccade_to(self, target, latency_ms: int = 0) -> SaccadePlan:
        """Plan a binocular saccade to ``target`` (object name or world point) starting
        ``latency_ms`` from now. Vergence follows from depth, torsion from Listing's law; with
        ``endpoint_noise`` the executed endpoint is perturbed (``plan.target`` vs
        ``plan.intended_target``). Nothing moves until :meth:`start_saccade`."""
        latency_ms = _ms("latency_ms", latency_ms)
        p = self._resolve(target)
        return self._plan_head(self.to_head(p), latency_ms, intended_world=p)

    def plan_saccade(self, horizontal: float, vertical: float, latency_ms: int = 0) -> SaccadePlan:
        """Plan a saccade by a retinotopic (cyclopean) displacement: ``horizontal`` (> 0 right)
        and ``vertical`` (> 0 up) Fick angles in radians relative to the current gaze, at the
        current fixation distance."""
        latency_ms = _ms("latency_ms", latency_ms)
        hv = np.array([_angle("horizontal", horizontal), _angle("vertical", vertical)])
        p_head = displaced(self._eye_centres_head.mean(axis=0), self._fix_head[None], hv[None])[0]
        return self._plan_head(p_head, latency_ms, intended_world=self.to_world(p_head))

    def _plan_head(self, p_head, latency_ms, intended_world) -> SaccadePlan:
        if self._plan is not None:
            raise RuntimeError("a saccade is in flight; step until it ends (plan.end_ms) before planning the next")
        c, p = self._eye_centres_head.mean(axis=0), np.asarray(p_head, float)[None]
        end = fixation_angles(p[0], self._eye_centres_head)[None]  # validates the intended target
        amp = cyclopean_amplitude(c, self._fix_head[None], p)
        end_point, noisy_end, noisy_amp = noisy_endpoints(
            c, self._eye_centres_head, self._fix_head[None], p, end, amp, self.motor_noise, [self._rng]
        )
        legacy = self.saccade_model == "legacy"
        return SaccadePlan(
            onset_ms=self.time_ms + latency_ms,
            start_angles=self._hold.copy(),
            end_angles=noisy_end[0],
            amplitude=float(noisy_amp[0]),
            generator=self.main_sequence if legacy else self.generator,
            target=self.to_world(end_point[0]),
            intended_target=np.asarray(intended_world, float),
            intended_end_angles=end[0],
            intended_amplitude=float(amp[0]),
            vergence=self.vergence,
            eye_position=self.eye_position,
            signal_start_angles=self._signal_hold_at(self.time_ms + latency_ms),
        )

    def start_saccade(self, plan: SaccadePlan) -> None:
        """Make ``plan`` the active eye command; the eyes move from ``plan.onset_ms`` on."""
        if not isinstance(plan, SaccadePlan):
            raise checks.InputTypeError(
                f"plan must be a SaccadePlan (from plan_saccade or plan_saccade_to); got {type(plan).__name__}"
            )
        if self._plan is not None:
            raise RuntimeError("a saccade is already in flight")
        if plan.onset_ms < self.time_ms:
            raise ValueError(f"plan onset {plan.onset_ms} ms is in the past (now {self.time_ms} ms)")
        if not np.allclose(plan.start_angles, self._hold, atol=1e-9):
            raise ValueError("plan does not start from the current eye position; plan it again")
        self._plan = plan
        self._servo.forget()
        self.last_plan = plan
        self._signal_plan = plan
        self._fix_head = self.to_head(plan.target)

    @property
    def saccade_in_flight(self) -> bool:
        """True from :meth:`start_saccade` until the plan's endpoint is reached."""
        return self._plan is not None

    def run_saccade(self, plan: SaccadePlan, before_ms: int = 0, after_ms: int = 0) -> Iterator[int]:
        """Start ``plan`` and step 1 ms at a time from ``before_ms`` before onset to ``after_ms``
        after ``plan.end_ms``, yielding the time relative to onset at each instant (render, flash
        or act there; the state is that of the yielded instant). The arguments are checked at the
        call; the saccade starts at the first iteration."""
        if not isinstance(plan, SaccadePlan):
            raise checks.InputTypeError(f"plan must be a SaccadePlan; got {type(plan).__name__}")
        return self._run_saccade(plan, _ms("before_ms", before_ms), _ms("after_ms", after_ms))

    def _run_saccade(self, plan: SaccadePlan, before_ms: int, after_ms: int) -> Iterator[int]:
        self.start_saccade(plan)
        t0 = plan.onset_ms - before_ms
        if self.time_ms < t0:
            self.step_ms(t0 - self.time_ms)
        stop = plan.end_ms + after_ms
        while True:
            yield self.time_ms - plan.onset_ms
            if self.time_ms >= stop:
                break
            self.step_ms(1)

    def saccade_to(self, target, latency_ms: int = 0, after_ms: int = 0) -> SaccadePlan:
        """Plan, execute and finish a saccade to ``target`` (one RL step); returns the plan."""
        after_ms = _ms("after_ms", after_ms)
        plan = self.plan_saccade_to(target, latency_ms)
        for _ in self.run_saccade(plan, after_ms=after_ms):
            pass
        return plan

    # ------------------------------------------------------------------ stepping
    def _command_at(self, t_ms: np.ndarray) -> np.ndarray:
        if self._plan is None:
            return np.broadcast_to(self._hold, t_ms.shape + (2, 3)).copy()
        return self._plan.angles(t_ms)

    @overload
    def step_ms(self, n: int = 1, record: Literal[False] = False) -> None: ...
    @overload
    def step_ms(self, n: int = 1, *, record: Literal[True]) -> EyeTrace: ...
    @overload
    def step_ms(self, n: int, record: Literal[True]) -> EyeTrace: ...
    @overload
    def step_ms(self, n: int = 1, record: bool = False) -> EyeTrace | None: ...
    def step_ms(self, n: int = 1, record: bool = False) -> EyeTrace | None:
        """Advance the simulation by ``n`` whole milliseconds; flashes due to end by then are hidden.

        While no saccade is in flight the servo set-points are constant and the physics runs in C
        (one ``mj_step(nstep=...)`` call at ``timestep_ms``) up to the next plan onset or the end.
        During a saccade each millisecond is ``1 / saccade_timestep_ms`` physics steps whose
        set-points (position, velocity, inverse-dynamics torque) follow the plan. With ``record``
        returns an :class:`EyeTrace` sampled at every physics step (so at ``timestep_ms`` during
        fixation and ``saccade_timestep_ms`` during saccades). ``n`` is at most ``MAX_STEP_MS``.
        """
        n = _ms("n", n)
        record = checks.flag("record", record)
        m, d = self.model, self.data
        rec: list[tuple] | None = [] if record else None
        stop = self.time_ms + n
        while self.time_ms < stop:
            plan = self._plan
            if plan is not None and self.time_ms >= plan.end_ms:
                self._finish_saccade()
                continue
            if plan is not None and self.time_ms >= plan.onset_ms:
                until = min(stop, plan.end_ms)
                self._servo.saccade(plan, self.time_ms, until, rec)
                self.time_ms = until
            else:
                until = stop if plan is None else min(stop, plan.onset_ms)
                self._servo.hold(self._hold, self.time_ms, until - self.time_ms, rec)
                self.time_ms = until
        if self._plan is not None and self.time_ms >= self._plan.end_ms:
            self._finish_saccade()
        self._servo.rest()
        if self._flash_off:  # flashes only matter to renders, which happen between calls
            for gid, off in list(self._flash_off.items()):
                if self.time_ms >= off:
                    m.geom_rgba[gid, 3] = 0.0
                    del self._flash_off[gid]
        mujoco.mj_forward(m, d)
        if rec is None:
            return None
        if not rec:
            z = np.zeros((0, 2, 3))
            return EyeTrace(np.zeros(0), z, z, z, z, z)
        t_list, qs, vs, ps = zip(*rec)
        ts = np.array(t_list)
        sp = self._signal_plan
        if sp is None:
            intended = np.broadcast_to(self._hold, ts.shape + (2, 3)).copy()
            eps = np.broadcast_to(self._signal_hold, ts.shape + (2, 3)).copy()
        else:
            intended, eps = sp.intended_angles(ts), sp.eye_position_signal(ts)
        return EyeTrace(
            ts,
            np.array(qs).reshape(-1, 2, 3),
            np.array(vs).reshape(-1, 2, 3),
            np.array(ps).reshape(-1, 2, 3),
            intended,
            eps,
        )

    def _finish_saccade(self) -> None:
        plan = self._plan
        assert plan is not None, "a saccade in flight to finish"
        assert plan.intended_end_angles is not None, "SaccadePlan.__post_init__ fills intended_end_angles"
        self._hold = plan.end_angles.copy()
        self._signal_hold = plan.intended_end_angles.copy()
        self._plan = None

    def _signal_hold_at(self, t_ms: float) -> np.ndarray:
        """Where the eye-position signal will be at ``t_ms`` if no new saccade starts."""
        plan = self._signal_plan
        if plan is None:
            return self._signal_hold.copy()
        t = float(t_ms)
        # the env reads the signal for its observation, then plans the next saccade from it at the
        # same time: one evaluation serves both (keyed by the plan, its signal timing and the time)
        memo = self._signal_memo
        if memo is None or memo[0] is not plan or memo[1] is not plan.eye_position or memo[2] != t:
            memo = self._signal_memo = (plan, plan.eye_position, t, plan.eye_position_signal(t))
        return memo[3].copy()

    def eye_position_signal(self, t_ms: float | None = None) -> np.ndarray:
        """The brain's estimate of both eyes' orientation (Fick angles (2, 3), rad) at sim time
        ``t_ms`` (default: now), from the last saccade's efference copy (``SaccadePlan.eye_position_signal``);
        the fixation set by ``reset``/``set_gaze`` before any saccade. Compare :attr:`eye_angles`
        (the true orientation)."""
        t = float(self.time_ms) if t_ms is None else checks.real("t_ms", t_ms, 0.0, None, hint="sim milliseconds")
        return self._signal_hold_at(t)
