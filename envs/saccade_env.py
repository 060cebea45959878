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

    **One step = one saccade and the fixation that follows it.** The agent picks the next saccade;
    the env plans it, predicts each eye's post-saccadic retina from the *pre*-saccadic DPFT
    coefficients and the efference copy (before the eyes move), runs the physics through the saccade
    and ``fixation_ms`` of fixation, renders both eyes, samples them on the exp-polar retina and takes
    the DPFT.

    - **Actions**: ``action_mode="vector"`` (default), ``Box(-1, 1, (2,))``: the saccade as Fick-angle
      increments x ``max_amplitude_deg`` (a third component with ``vergence=True``);
      ``action_mode="cell"``, ``Discrete(M * N)``: saccade to a peripheral retina cell's direction.
    - **Observations** (``spaces.Dict``, float32 in [0, 1]): ``cortical`` ``(2, M, N, C)`` (or the
      ``cortex="hemispheres"`` map), ``fovea`` ``(2, N_f, C)``, ``remapped`` (the prediction, shaped as
      ``cortical``), ``eyes`` ``(2, 3)`` (the eye-position signal, not the true eye), ``coeffs`` (optional).
    - **Reward**: the task's, the sum of the ``reward_*`` components of ``info``.
    - **Episode end**: terminated when the task succeeds, truncated after its saccade budget
      ``max_saccades`` (the registered ``max_episode_steps``: one truncation, not two).
    - **info**: ``remap_error`` per model, the saccade's kinematics and errors, ``efference_copy``,
      ``executed_rotation``, ``eye_angles`` (ground truth), ``success``, ``clipped``, ``reward_*``.
    - Not picklable or copyable (a ``TypeError`` says to make a new env and replay the seed and actions).

    Every argument is checked at construction (``ValueError``/``TypeError`` naming it). The spaces,
    rewards, episode ends, ``info`` keys, every argument and the version history in full: docs/env.md
    ("The environment", section "BinocularSaccadeEnv in full").
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
