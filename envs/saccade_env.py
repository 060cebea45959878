"""``BinocularSaccade-v0``: saccades in, conformal-camera cortical observations out."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np

import conformal as C
import models
from conformal import checks

from . import core
from .actions import cell_angles, decode_actions
from .tasks import Task, _gaze_errors_deg, make_task
from .vision import POOLED_REMAP_DEFAULT, REMAP_MODELS, EyeView, Vision, _Frame

__all__ = ["BinocularSaccadeEnv"]


class BinocularSaccadeEnv(gym.Env):
    """A binocular head whose eyes are conformal cameras, making one saccade per step.

    **One step = one saccade and the fixation that follows it.** The agent picks the next
    saccade; the env plans it on the main sequence, computes the predicted post-saccadic
    retina of each eye from the *pre*-saccadic DPFT coefficients and the efference copy
    (before the eyes move), runs the physics through the saccade and ``fixation_ms`` of
    fixation, renders both eyes, samples them on the exp-polar retina and takes the DPFT.

    **Action space.**
    ``action_mode="vector"`` (default): ``Box(-1, 1, (2,))``, the saccade (horizontal > 0
    right, vertical > 0 up) as Fick-angle increments relative to the current gaze, scaled by
    ``max_amplitude_deg``; with ``vergence=True`` a third component in [-1, 1] changes the
    fixation distance by a factor 2**a. ``action_mode="cell"``: ``Discrete(M * N)``, a
    peripheral retina cell ``k * N + l`` (a superior-colliculus-like motor map): saccade to
    the direction of that cell's centre. Saccades that would leave the oculomotor range are
    shortened to its edge (``info["clipped"]``). NaN, infinite or out-of-space actions raise
    ``ValueError``; actions of the wrong type (complex, bool, strings; a float in cell mode) raise
    ``TypeError`` (``conformal.checks.InputTypeError``, also a ``ValueError``).

    **Observation space** (``spaces.Dict``, float32; M rings, N sectors, N_f foveal samples,
    C = 3, or 1 with ``grayscale=True``; values are intensities in [0, 1]):

    - ``cortical``: both eyes' peripheral log-polar samples, ``(2, M, N, C)`` [eye, ring, sector];
      with ``cortex="hemispheres"`` the binocular cortical map ``(2, 2, M, N/2, C)``
      [hemisphere (left, right), eye (left, right), ring, sector-in-hemifield].
    - ``fovea``: both eyes' foveal samples, ``(2, N_f, C)``.
    - ``remapped``: the predicted post-saccadic cortical samples of ``remap_model``, computed
      from the pre-saccadic coefficients and the efference copy; same shape as ``cortical``
      (cells whose source is unknown, e.g. beyond the old picture, are 0; values clipped to [0, 1]).
      At reset it equals ``cortical``.
    - ``eyes``: the eye-position signal: the agent's (extraretinal) estimate of both eyes' Fick
      angles ``(2, 3)`` [eye, (horizontal, vertical, torsion)], radians, from the efference copy
      (``models.Head.eye_position_signal``); not the true orientation, which ``info["eye_angles"]``
      reports as ground truth. With ``endpoint_noise`` the two differ by the motor error.
    - ``coeffs`` (``include_coeffs=True``): the DPFT coefficients ``(2, M, N, C, 2)`` (real, imag).

    **Reward**: from the task, the sum of the components that ``info`` reports as ``reward_*``
    (``task.reward_keys``, as Gymnasium's MuJoCo envs report ``reward_ctrl``...). ``fixate``:
    ``reward_target`` = exp(-(e/tol)^2/2), e the mean gaze error to the target, plus
    ``reward_saccade`` = -``saccade_cost`` (-0.05) per saccade. ``search``: ``reward_target`` = 1 for
    foveating the target (else 0) plus ``reward_saccade`` = -0.05. ``free``: free viewing of any
    scene, reward 0 and no ``reward_*`` keys.

    **Episode end**: terminated when the task succeeds (``fixate``, ``search``: the target foveated,
    both eyes within ``tolerance_deg``; ``free`` never); truncated after the task's saccade budget
    ``max_saccades`` (steps: one saccade each): 5 for ``fixate``, 10 for ``search``, 20 for ``free``
    (``task_kwargs={"max_saccades": n}`` changes it). The registered ids carry the same limit as
    ``max_episode_steps`` (``BinocularSaccade-v0``: 5, ``BinocularSaccadeSearch-v0``: 10), so
    ``gymnasium.make(id).spec.max_episode_steps`` is set and Gymnasium's ``TimeLimit`` truncates at the
    step the env itself does: one truncation (both flags are the same ``truncated``), not two.
    ``gymnasium.make(id, max_episode_steps=K)`` truncates after min(K, ``max_saccades``) steps: for
    longer episodes raise the budget too (``task_kwargs={"max_saccades": K}``); with another task or
    budget pass the matching ``max_episode_steps``, or ``max_episode_steps=-1`` to leave truncation
    to the env's budget alone.

    **info**: ``sim_time_ms``; ``remap_error`` {model: normalized RMS error of its prediction
    against the actual post-saccadic samples, mean of both eyes} for every model in
    ``remap_models``; ``saccade_amplitude_deg``, ``saccade_duration_ms``,
    ``peak_velocity_deg_s``, ``landing_error_deg`` (gaze vs the intended endpoint),
    ``endpoint_error_deg`` (2,) (each eye's executed vs intended endpoint direction, from the motor
    noise), ``efference_copy`` (2, 3, 3) (the intended rotation of each eye, head frame),
    ``executed_rotation`` (2, 3, 3) (the rotation made), ``eye_angles`` (2, 3) (the true Fick angles),
    ``target_error_deg`` (tasks with a target), ``success``, ``clipped``, and the reward's
    components ``reward_*`` (above).

    **Copies**: the env holds a compiled MuJoCo model and an OpenGL context, so ``pickle`` and
    ``copy`` (deep or shallow) refuse it with a ``TypeError`` saying what to do instead: make a new
    env with the same arguments (``gymnasium.make(env.spec.id, **env.spec.kwargs)``) and, for the
    same state, reset it with the same seed and replay the actions (the env is deterministic under a seed).

    **Arguments**: ``scene`` (default: the task's), ``task`` (``"fixate"``, ``"search"``, ``"free"`` or a
    ``Task``), ``action_mode``, ``image_size`` (pixels per side of each eye's image, an integer in
    [16, 1024]), ``render_mode`` (``"rgb_array"``), ``fixation_ms`` (250; whole ms in [0, 10000]),
    ``max_amplitude_deg`` (30; in (0, 60]),
    ``vergence``, ``remap_model`` (``"homography"``, ``"mobius"``, ``"shift"``),
    ``remap_models`` (models whose error ``info`` reports; default all three), ``shift_rings``
    (the shift model's log-radius compression), ``pooled_remap`` (False: each prediction is the
    series at the receptive field's centre; True: averaged over the field as the pooled retina
    averages the picture (``conformal.RemapPlan``'s ``pooled``), closer to the samples (bar scene,
    20 deg saccades from straight ahead: homography error 0.19 -> 0.13) at about 0.1 ms more per
    step; see ``envs.vision.POOLED_REMAP_DEFAULT``; it changes ``remapped`` and ``remap_error``,
    nothing else), ``grayscale``, ``cortex`` (``"eyes"`` or
    ``"hemispheres"``), ``include_coeffs``, ``fovea_deg`` (3), ``n_sectors``, ``sampling``
    (``"pool"``), ``fovy_deg`` (70), ``endpoint_noise`` (0) or ``motor_noise`` (a ``models.MotorNoise``), ``saccade_model`` (``"burst"`` or
    ``"legacy"``, see ``models.Head``), ``generator`` (a ``models.BurstGenerator``, e.g. one fitted to a
    person's recording: ``models.BurstGenerator.from_file``), ``eye_drive`` (``"plant"``: torques through
    the orbital plant, or ``"servo"``: exact pointing; see ``models.Head``), ``quality`` (``"fast"``),
    ``task_kwargs``. Flags (``vergence``, ``grayscale``, ``include_coeffs``, ``pooled_remap``) must be bools; every
    argument is checked at construction (``ValueError``/``TypeError`` naming it).

    **Version history**: v0 — initial version; later, without changing the default episodes,
    rewards or observations: registered with ``max_episode_steps`` (the task's default budget; a
    ``gymnasium.make`` that changes the task or its budget now passes the matching limit too, see
    above), ``info`` reports the reward's ``reward_*`` components, and pickling or copying raises a
    clear ``TypeError``.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 4}
    #: The longest fixation after a saccade (ms): 10 s, far beyond human fixations (180-320 ms).
    MAX_FIXATION_MS = core.MAX_FIXATION_MS

    def __init__(
        self,
        scene: str | None = None,
        task: str | Task = "fixate",
        action_mode: str = "vector",
        image_size: int = 128,
        render_mode: str | None = None,
        *,
        fixation_ms: int = 250,
        max_amplitude_deg: float = 30.0,
        vergence: bool = False,
        remap_model: str = "homography",
        remap_models: tuple[str, ...] | None = None,
        shift_rings: float = 0.0,
        pooled_remap: bool = POOLED_REMAP_DEFAULT,
        grayscale: bool = False,
        cortex: str = "eyes",
        include_coeffs: bool = False,
        fovea_deg: float = 3.0,
        n_sectors: int | None = None,
        sampling: str = "pool",
        fovy_deg: float = models.DEFAULT_FOVY_DEG,
        endpoint_noise: float = 0.0,
        saccade_model: str = "burst",
        generator: models.BurstGenerator | None = None,
        eye_drive: str = "plant",
        quality: str = "fast",
        task_kwargs: dict | None = None,
        motor_noise: models.MotorNoise | None = None,
    ) -> None:
        super().__init__()
        checks.choice("action_mode", action_mode, ("vector", "cell"))
        checks.choice("render_mode", render_mode, ("rgb_array",), allow_none=True)
        checks.choice("cortex", cortex, ("eyes", "hemispheres"))
        checks.choice("remap_model", remap_model, REMAP_MODELS)
        if remap_models is None:
            remap_models = REMAP_MODELS
        elif isinstance(remap_models, str) or not isinstance(remap_models, (list, tuple)):
            raise checks.InputTypeError(
                f"remap_models must be a tuple of model names from {REMAP_MODELS} or None; got {remap_models!r}"
            )
        remap_models = tuple(
            dict.fromkeys(checks.choice("each of remap_models", m, REMAP_MODELS) for m in remap_models)
        )
        if remap_model not in remap_models:
            remap_models = remap_models + (remap_model,)
        image_size = checks.integer("image_size", image_size, 16, 1024)
        self.fixation_ms = checks.integer(
            "fixation_ms",
            fixation_ms,
            0,
            self.MAX_FIXATION_MS,
            hint="whole milliseconds of fixation after each saccade",
        )
        max_amplitude_deg = checks.real("max_amplitude_deg", max_amplitude_deg, 0.0, 60.0, lo_open=True)
        self.vergence = checks.flag("vergence", vergence)
        self.include_coeffs = checks.flag("include_coeffs", include_coeffs)
        checks.flag("grayscale", grayscale)
        checks.flag("pooled_remap", pooled_remap)
        if task_kwargs is not None and not isinstance(task_kwargs, dict):
            raise checks.InputTypeError(f"task_kwargs must be a dict or None; got {type(task_kwargs).__name__}")
        self.task = make_task(task, **(task_kwargs or {}))
        if scene is not None and scene not in models.SCENES:
            raise (ValueError if isinstance(scene, str) else checks.InputTypeError)(
                f"unknown scene {scene!r}; choose one of {', '.join(models.SCENES)}"
            )
        self.scene = scene or self.task.scene
        self.action_mode = action_mode
        self.render_mode = render_mode
        self.max_amplitude = math.radians(max_amplitude_deg)
        self.remap_model = remap_model
        self.remap_models = remap_models
        self.cortex = cortex

        self.head = models.Head(
            self.scene,
            image_size=image_size,
            fovy_deg=fovy_deg,
            quality=quality,
            seed=0,
            endpoint_noise=endpoint_noise,
            saccade_model=saccade_model,
            generator=generator,
            eye_drive=eye_drive,
            motor_noise=motor_noise,
        )
        try:
            self.task.check_scene(self.head)
        except ValueError:
            self.head.close()
            raise
        try:
            self.vision = Vision(
                self.head.image_shape,
                self.head.pixels_per_unit,
                fovea_deg=fovea_deg,
                n_sectors=n_sectors,
                grayscale=grayscale,
                sampling=sampling,
                shift_rings=shift_rings,
                pooled_remap=pooled_remap,
            )
            g = self.vision.grid
            if cortex == "hemispheres" and g.N % 4:
                raise ValueError(f"cortex='hemispheres' needs N divisible by 4; got n_sectors={g.N}")
        except Exception:
            self.head.close()
            raise
        self.observation_space = core.observation_space(g, self.vision.channels, cortex, include_coeffs)
        self.action_space = core.action_space(action_mode, vergence, g)
        self._cells = None if action_mode == "vector" else cell_angles(g.points)  # saccade to each cell
        self._views: tuple[EyeView, ...] | None = None
        self._seen: _Frame | None = None  # the last frame's views and arrays
        self._remapped: np.ndarray | None = None
        self._frame: models.StereoFrame | None = None
        self._saccades = 0

    # ------------------------------------------------------------------ gym API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        seed = core.check_seed(seed)
        core.check_options(options)
        super().reset(seed=seed)
        self.head.reset(seed=core.head_seed(self.np_random))
        self.task.initialize_episode(self.head, self.np_random)
        self._saccades = 0
        seen = self._see()
        self._remapped = self._cortical(seen.periphery)
        return self._observation(), core.reset_info(self.head.time_ms, {m: 0.0 for m in self.remap_models})

    def step(self, action):
        core.require_reset(self._views is not None)
        h, v, dist_factor = self._decode(action)
        plan, clipped = self._plan(h, v, dist_factor)
        # the per-step path: the views, coefficients and models were checked (or made) by this env,
        # so Vision's internal entry points skip re-checking them (the efference copy is checked)
        values, valid = self.vision._predict_frame(self._seen, self.remap_models, plan.efference_copy_eye)
        self.head.start_saccade(plan)
        self.head.step_ms(plan.end_ms - self.head.time_ms + self.fixation_ms)
        self._see()
        per_eye_errors = self.vision._frame_errors(values, valid, self._seen)
        errors = {m: float(e) for m, e in zip(self.remap_models, per_eye_errors.mean(axis=0))}
        g = self.vision.grid
        chosen = values[:, self.remap_models.index(self.remap_model), g.n_fovea :]  # invalid cells hold 0
        self._remapped = self._cortical(chosen.reshape(2, g.M, g.N, -1))
        reward, success, tinfo = self.task.score(self.head)
        self._saccades += 1
        terminated, truncated = (bool(f) for f in core.episode_end(success, self._saccades, self.task.max_saccades))
        landing = _gaze_errors_deg(self.head, plan.intended_target).mean()
        info = core.step_info(
            self.head.time_ms, errors, core.saccade_info(plan), float(landing), self.head.eye_angles, clipped, tinfo
        )
        return self._observation(), float(reward), terminated, truncated, info

    @property
    def seen(self):
        """What vision made of the last frame (both eyes' retina samples, DPFT coefficients and fovea
        arrays: ``frame.coeffs``, ``frame.fovea``, ``frame.periphery``); None before ``reset``."""
        return self._seen

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        core.require_reset(self._frame is not None, "render()")
        from .display import compose_frame

        return compose_frame(self._frame, self._views, self.vision)

    def close(self) -> None:
        self.head.close()

    def __reduce_ex__(self, protocol):
        # pickle, copy.deepcopy and copy.copy all come here first: refuse before anything (a half-built
        # copy of the GL renderer, whose __del__ would print a traceback) is made
        raise core.no_copy(type(self).__name__)

    # ------------------------------------------------------------------ helpers
    def _see(self) -> _Frame:
        """Render both eyes and see the frame (kept as ``_frame``, ``_seen``, ``_views``); returns ``_seen``."""
        frame = self.head.render()
        seen = self.vision._see_frame((frame.left.image, frame.right.image))
        self._frame, self._seen, self._views = frame, seen, seen.views
        return seen

    def _cortical(self, per_eye: np.ndarray) -> np.ndarray:
        """Both eyes' peripheral samples (2, M, N, C) as the ``cortical`` observation (float32 in [0, 1])."""
        if self.cortex == "eyes":
            out = per_eye
        else:
            bc = C.binocular_cortex(per_eye[0], per_eye[1], self.vision.grid)
            out = np.stack([bc.left_hemisphere, bc.right_hemisphere])
        return np.clip(out, 0.0, 1.0).astype(np.float32, copy=False)

    def _observation(self) -> dict[str, np.ndarray]:
        seen, remapped = self._seen, self._remapped
        assert seen is not None and remapped is not None, "reset() sees the first frame before any observation"
        coeffs = None
        if self.include_coeffs:
            cf = np.stack([v.coeffs for v in seen.views])
            coeffs = np.stack([cf.real, cf.imag], axis=-1).astype(np.float32)
        return core.observation(
            self._cortical(seen.periphery),
            np.clip(seen.fovea, 0.0, 1.0).astype(np.float32),
            remapped.copy(),
            self.head.eye_position_signal().astype(np.float32),
            coeffs,
        )

    def _decode(self, action) -> tuple[float, float, float]:
        """Action -> (horizontal, vertical) Fick increments (rad) and a fixation-distance factor."""
        shape = self.action_space.shape
        assert shape is not None, "the env's action spaces (Box, Discrete) have a shape"
        hv, factor = decode_actions(
            action, shape, cells=self._cells, max_amplitude=self.max_amplitude, vergence=self.vergence
        )
        return float(hv[0, 0]), float(hv[0, 1]), float(factor[0])

    def _plan(self, h: float, v: float, factor: float):
        return models.plan_clipped(self.head, h, v, factor)
