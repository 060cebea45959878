"""``BatchedBinocularSaccade``: N binocular heads stepped at once, physics and vision on a device.

The vector entry point of ``BinocularSaccade-v0``::

    envs = gymnasium.make_vec("BinocularSaccade-v0", num_envs=1024, vectorization_mode="vector_entry_point",
                              device="cuda")

Each world is one ``BinocularSaccadeEnv`` episode: the same spaces, tasks, rewards, seeding and
info keys. What runs where, per step:

* host (numpy and numba, all worlds at once): the action's decoding (``envs.actions``, as the single
  env's), the saccade plans, command tables, efference copies and eye-position signals
  (``models.BatchedPlanner`` and ``models.SaccadePlans``: the code ``models.Head`` and
  ``models.SaccadePlan`` run for one head), the servo's set-points (``models.servo_setpoints``) and
  the task's score of the gaze errors (``Task.score_errors``), i.e. the brain's side; episode resets
  world by world on one host ``models.Head`` (the settled state of ``Head.reset`` with each world's
  own seed, ``models.SettledReset``), with no CPU physics and no CPU rendering;
* device: the remapping predictions of every model from the previous frame and the efference
  copies (``envs.batched_vision.TorchVision``), the physics (MuJoCo Warp, a kernel reading each
  world's set-points, ``envs.batched_physics.WarpHeads``), both eyes rendered by MJWarp's batch
  renderer, retina pooling, DPFT and remapping errors.

Observations stay on the device as torch tensors (``output="torch"``, default) or come back as
numpy arrays (``output="numpy"``). Rewards, terminations and truncations are numpy arrays (the
autoreset needs them on the host anyway); ``info`` holds numpy arrays with gymnasium's ``_key``
masks. Autoreset: ``NEXT_STEP`` (gymnasium's default): the step after a world's episode ends
resets it and ignores its action.
"""

from __future__ import annotations

import contextlib
import time
from typing import TYPE_CHECKING, Any

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from conformal import checks
from models import BatchedPlanner, SettledReset

from . import core
from .actions import decode_actions
from .saccade_env import BinocularSaccadeEnv
from .tasks import FixateTask, FreeViewingTask, SearchTask, Task, gaze_errors

if TYPE_CHECKING:
    from torch import Tensor

    from .batched_vision import TorchFrame

__all__ = ["BatchedBinocularSaccade", "MAX_NUM_ENVS"]

#: The most worlds one batched env holds.
MAX_NUM_ENVS = 65_536
_TASKS = (FixateTask, SearchTask, FreeViewingTask)


def _resolve_device(device, wp, torch) -> str:
    """The device both Warp and torch can use: CUDA needs a CUDA build of torch as well as Warp's CUDA."""
    cuda = wp.is_cuda_available() and torch.cuda.is_available()
    if device is None:
        return "cuda" if cuda else "cpu"
    if not isinstance(device, str):
        raise checks.InputTypeError(
            f"device must be a string such as 'cuda', 'cuda:1' or 'cpu', or None; got {device!r}"
        )
    if device != "cpu" and not device.startswith("cuda"):
        raise ValueError(f"device must be 'cuda', 'cuda:<index>' or 'cpu'; got {device!r}")
    if device.startswith("cuda") and not wp.is_cuda_available():
        raise RuntimeError(
            f"device={device!r} but Warp finds no CUDA device here; use device='cpu' (Warp's CPU "
            "backend: slow, for tests) or run on a machine with an NVIDIA GPU"
        )
    if device.startswith("cuda") and not torch.cuda.is_available():
        raise RuntimeError(
            f"device={device!r}: Warp finds a CUDA device but this torch is a CPU-only build "
            f"(torch {torch.__version__}); install a CUDA build of torch (see pytorch.org) or use "
            "device='cpu'"
        )
    return device


class BatchedBinocularSaccade(VectorEnv):
    """``num_envs`` worlds of ``BinocularSaccadeEnv`` stepped together (see the module docstring).

    Args:
        num_envs: the number of worlds, an integer in [1, 65536].
        device: ``"cuda"`` (or ``"cuda:<i>"``), ``"cpu"`` (Warp's CPU backend: slow, for tests) or None
            (CUDA when Warp finds it, else CPU).
        output: ``"torch"`` (observations as torch tensors on the device) or ``"numpy"``.
        chunk_ms: physics steps per captured CUDA graph (see ``envs.batched_physics.WarpHeads``).
        linear_tail: take each step's slow stretch of physics in closed form (``models.linear_tail``,
            within 1e-4 deg of stepping); None (default): off where the physics is fused, off on CUDA
            until it is measured there (``envs.batched_physics.WarpHeads``).
        fused_physics: step each env step's physics in one Warp kernel launch (``envs._warp_dynamics``:
            MuJoCo's ``implicitfast`` step for the head's hinges and their limits, float64, within
            ~1e-6 deg of MuJoCo's C ``mj_step``) instead of MuJoCo Warp's ~50 launches per millisecond;
            None (default): on Warp's CPU backend, off on CUDA until it is measured there.
        autoreset_mode: ``"next_step"`` (default, gymnasium's) or ``"same_step"`` (the world is reset
            within the step that ended it; the ended episode's last observations and info are in
            ``info["final_obs"]`` / ``info["final_info"]``, masked by ``info["_final_obs"]``).
        retina_rays: None (default: a pinhole image per eye, pooled on the retina) or s in [1, 8]: render
            the retina natively, s x s rays per receptive field (``envs.retina_rays``).
        max_episode_steps: None or -1 (the task's saccade budget alone) or K >= 1: truncate after
            min(K, ``max_saccades``) steps, as ``TimeLimit(K)`` around the single env does.
        settle_ms: physics milliseconds simulated after the last world's saccade ends (default 20); the
            rest of the fixation is only a clock.
        **kwargs: the single env's arguments, each checked as ``BinocularSaccadeEnv`` checks it; not
            ``render_mode``, ``pooled_remap=True`` or tasks other than ``fixate``, ``search``, ``free``.

    The first step on a new machine compiles Warp's kernels (about 30 s on the CPU backend, a minute
    on CUDA). Each argument in full: docs/batched.md ("Batched env", section "Inside the batched env").
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(
        self,
        num_envs: int,
        device: str | None = None,
        *,
        output: str = "torch",
        chunk_ms: int = 25,
        settle_ms: int = 20,
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
        retina_rays: int | None = None,
        max_episode_steps: int | None = None,
        linear_tail: bool | None = None,
        fused_physics: bool | None = None,
        **kwargs: Any,
    ) -> None:
        from .batched_physics import WarpHeads, require_gpu_extra
        from .batched_vision import TorchVision

        wp, _, torch = require_gpu_extra()
        self._torch = torch
        self.num_envs = checks.integer("num_envs", num_envs, 1, MAX_NUM_ENVS)
        self.output = checks.choice("output", output, ("torch", "numpy"))
        chunk_ms = checks.integer("chunk_ms", chunk_ms, 1, 1000)
        if linear_tail is not None:
            linear_tail = checks.flag("linear_tail", linear_tail)
        if fused_physics is not None:
            fused_physics = checks.flag("fused_physics", fused_physics)
        self.settle_ms = checks.integer("settle_ms", settle_ms, 0, core.MAX_FIXATION_MS)
        modes = {"next_step": AutoresetMode.NEXT_STEP, "same_step": AutoresetMode.SAME_STEP}
        if isinstance(autoreset_mode, AutoresetMode):
            autoreset_mode = {m: k for k, m in modes.items()}.get(autoreset_mode, autoreset_mode.value)
        self.autoreset_mode = modes[checks.choice("autoreset_mode", autoreset_mode, tuple(modes))]
        self.metadata = {**self.metadata, "autoreset_mode": self.autoreset_mode}
        if retina_rays is not None:
            from .retina_rays import MAX_SUBSAMPLES

            retina_rays = checks.integer(
                "retina_rays",
                retina_rays,
                1,
                MAX_SUBSAMPLES,
                hint="sub-rays per receptive-field side, or None for pinhole images",
            )
        self.retina_rays = retina_rays
        max_episode_steps = core.saccade_budget(Task.MAX_SACCADES, max_episode_steps)  # checked before the env
        device = _resolve_device(device, wp, torch)
        if kwargs.get("render_mode") is not None:
            raise ValueError(
                "the batched env does not render for display (render_mode must be None); "
                "use BinocularSaccadeEnv(render_mode='rgb_array') to look at an episode"
            )
        if kwargs.get("pooled_remap"):
            raise ValueError(
                "pooled_remap=True is not available in the batched env (its remapping predictions are "
                "the point prediction); use BinocularSaccadeEnv for pooled predictions"
            )
        self._template = env = BinocularSaccadeEnv(**kwargs)  # checks every single-env argument
        if type(env.task) not in _TASKS:
            env.close()
            raise ValueError(
                f"the batched env scores the built-in tasks fixate, search and free on the device; "
                f"got a {type(env.task).__name__}"
            )
        self.task = env.task
        self._max_steps = core.saccade_budget(env.task.max_saccades, max_episode_steps)  # as TimeLimit(K) caps it
        self.single_observation_space = env.observation_space
        self.single_action_space = env.action_space
        self.observation_space = batch_space(env.observation_space, self.num_envs)
        self.action_space = batch_space(env.action_space, self.num_envs)
        self.render_mode = None
        self.remap_models, self.remap_model = env.remap_models, env.remap_model
        self._chosen = env.remap_models.index(env.remap_model)
        self.head = env.head  # one host head for all worlds: resets, geometry, and the rare per-world planning
        self.planner = BatchedPlanner(env.head, self.num_envs)
        self._settled = SettledReset(env.head)
        directions = None
        if retina_rays is not None:
            from .retina_rays import field_ray_directions

            directions = field_ray_directions(env.vision.grid, retina_rays)
        self.physics = WarpHeads(
            env.head,
            self.num_envs,
            device,
            chunk_ms=chunk_ms,
            retina_directions=directions,
            linear_tail=linear_tail,
            fused=fused_physics,
        )
        self.device = self.physics.torch_device
        self.vision = TorchVision(env.vision, self.physics.torch_device)
        self.grid = env.vision.grid
        self.max_amplitude = env.max_amplitude  #: radians: the saccade of a full-scale vector action (as the env's)
        m = env.head.model
        self._target_gid = m.geom("target").id if "target" in env.head.scene.objects else None
        self._cam_ids = torch.as_tensor(self.physics.cam_ids, device=self.device)
        self._rngs: list[np.random.Generator | None] = [None] * self.num_envs
        self._saccades = np.zeros(self.num_envs, np.int64)
        self._autoreset = np.zeros(self.num_envs, bool)
        self._frame: TorchFrame | None = None
        self._remapped: Tensor | None = None  # the remapped cortical observation (after reset)
        #: Set to a dict to accumulate each part's wall time per step (seconds, device synchronised
        #: around each part: slower; for benchmarks/batched.py); None (default) to time nothing.
        self.timings: dict[str, float] | None = None

    # ------------------------------------------------------------------ gym API
    def reset(self, *, seed: int | list[int] | None = None, options: dict | None = None):
        self._check_open()
        n = self.num_envs
        seeds = core.world_seeds(seed, n)
        core.check_options(options)
        for i, s in enumerate(seeds):
            if s is not None or self._rngs[i] is None:
                self._rngs[i], _ = seeding.np_random(s)
        self._reset_worlds(np.arange(n))
        self._autoreset[:] = False
        self._load(np.arange(n))
        self._see()
        self._remapped = self._cortical_now()
        info = core.reset_info(self.planner.time_ms.copy(), {m: np.zeros(n) for m in self.remap_models})
        return self._observation(), core.masked(info, np.ones(n, bool))

    def step(self, actions):
        self._check_open()
        core.require_reset(self._frame is not None)
        torch = self._torch
        n, g = self.num_envs, self.grid
        part = self._part
        with part("host"):
            hv, factor = self._decode(actions)
        resetting = self._autoreset.copy()
        active = ~resetting
        act = np.flatnonzero(active)
        with part("host"):
            self._reset_worlds(np.flatnonzero(resetting))
            rot_eye = np.broadcast_to(np.eye(3), (n, 2, 3, 3)).copy()
            clipped = np.zeros(n, bool)
            spans = np.zeros(n, np.int64)
            lengths = np.ones(n, np.int64)
            plans = None
            if len(act):
                plans, clipped[act] = self.planner.plan(act, hv[act], factor[act])
                rot_eye[act] = plans.efference_copy_eye
        # The host's work overlaps the device's (on CUDA, where torch's and Warp's launches return at
        # once): the command tables are built while the remapping predictions run, and the worlds'
        # clocks and eye-position signals advance while the physics steps.
        with part("remap"):
            values, valid = self.vision.predict(
                self._frame, torch.as_tensor(rot_eye, dtype=torch.float32, device=self.device), self.remap_models
            )
        with part("host"):
            # the command tables: each world's commanded angles at every ms from now to its saccade's end,
            # the worlds being reset holding their fixation (built in place in the planner's buffer)
            if plans is not None:
                commands, lengths = self.planner.commands(plans, act)
                spans[act] = plans.end_ms - plans.onset_ms
            else:
                commands = self.planner.hold.reshape(n, 1, 6).copy()
            advance = np.where(active, spans + self._template.fixation_ms, 0)
        with part("physics"):
            if resetting.any():
                self._load(np.flatnonzero(resetting))
            self.physics.run(commands, lengths, int(min(advance.max(), spans.max() + self.settle_ms)), wait=False)
        with part("host"):
            if plans is not None:
                self.planner.start(act, plans, advance[act])
        with part("physics"):
            self.physics.wait()
        with part("host sync"):
            eye_q = self.physics.eye_qpos().double().cpu().numpy()
        self._see()
        with part("remap"):
            errors = self.vision.errors(values, valid, self._frame).mean(dim=1)  # (N, K): mean of both eyes
            chosen = values[:, :, self._chosen, g.n_fovea :].reshape(n, 2, g.M, g.N, -1)
            remapped = self.vision.cortical(chosen, self._template.cortex)
            now = self._cortical_now()
            keep = torch.as_tensor(active, device=self.device).view((n,) + (1,) * (remapped.dim() - 1))
            self._remapped = torch.where(keep, remapped, now)
        with part("task"):
            target_err, landing = self._gaze_errors(plans, act, active)
            reward, success, parts = self.task.score_errors(target_err)
        self._saccades[active] += 1
        terminated, truncated = core.episode_end(success, self._saccades, self._max_steps, active)
        reward = np.where(active, reward, 0.0)
        if self.autoreset_mode is AutoresetMode.NEXT_STEP:
            self._autoreset = terminated | truncated

        errors = errors.double().cpu().numpy()
        saccade = {}
        for k, (shape, get) in core.SACCADE_INFO.items():  # zeros, and identities for the rotations
            saccade[k] = np.zeros((n,) + shape) if len(shape) < 2 else np.broadcast_to(np.eye(3), (n,) + shape).copy()
            if plans is not None:
                saccade[k][act] = get(plans)
        has_target = self._target_gid is not None and not isinstance(self.task, FreeViewingTask)
        task_info = core.task_info(
            success & active,
            {k: np.where(active, v, 0.0) for k, v in parts.items()},
            np.where(active, target_err.mean(axis=1), 0.0) if has_target else None,
        )
        info = core.masked(
            core.step_info(
                self.planner.time_ms.copy(),
                {m: np.where(active, errors[:, k], 0.0) for k, m in enumerate(self.remap_models)},
                saccade,
                landing,
                eye_q,
                clipped,
                task_info,
            ),
            active,
        )
        with part("host sync"):
            obs = self._observation()
        done = terminated | truncated
        if self.autoreset_mode is AutoresetMode.SAME_STEP and done.any():
            obs, info = self._reset_same_step(done, obs, info)
        return obs, reward, terminated, truncated, info

    def close_extras(self, **kwargs) -> None:
        """Release the host head (``VectorEnv.close`` calls this once and sets ``closed``)."""
        self.head.close()

    def __reduce_ex__(self, protocol):
        # pickle and copy refuse it before a half-built copy of its GL renderer or device state is made
        raise core.no_copy(type(self).__name__, "gymnasium.make_vec")

    # ------------------------------------------------------------------ helpers
    def _check_open(self) -> None:
        if self.closed:
            raise RuntimeError("this BatchedBinocularSaccade is closed; make a new one")

    def _reset_same_step(self, done: np.ndarray, final_obs: dict, final_info: dict) -> tuple[dict, dict]:
        """SAME_STEP autoreset: reset the ``done`` worlds now and render again; the ended episodes'
        last observations and infos go to ``info["final_obs"]`` / ``info["final_info"]``."""
        idx = np.flatnonzero(done)
        with self._part("host"):
            self._reset_worlds(idx)
        with self._part("physics"):
            self._load(idx)
        self._see()
        now = self._cortical_now()
        keep = self._torch.as_tensor(~done, device=self.device).view((-1,) + (1,) * (now.dim() - 1))
        self._remapped = self._torch.where(keep, self._remapped, now)
        with self._part("host sync"):
            obs = self._observation()
        # the reset worlds' remapping errors are a reset's (zeros), as BinocularSaccadeEnv.reset reports
        errors = {m: np.where(done, 0.0, v) for m, v in final_info["remap_error"].items() if not m.startswith("_")}
        info = {
            **core.masked(core.reset_info(self.planner.time_ms.copy(), errors), np.ones(self.num_envs, bool)),
            "final_obs": final_obs,
            "_final_obs": done.copy(),
            "final_info": self._mask_info(final_info, done),
            "_final_info": done.copy(),
        }
        for k, v in final_info.items():  # the running worlds' step info stays where it was
            if k not in info and not k.startswith("_") and not isinstance(v, dict):
                info[k], info["_" + k] = v.copy(), final_info["_" + k] & ~done
        return obs, info

    @contextlib.contextmanager
    def _part(self, name: str):
        """Time a part of the step into ``timings`` (when set), the device synchronised at both ends."""
        if self.timings is None:
            yield
            return
        dev = self.device
        sync = (lambda: self._torch.cuda.synchronize(dev)) if dev.type == "cuda" else (lambda: None)
        sync()
        t0 = time.perf_counter()
        yield
        sync()
        self.timings[name] = self.timings.get(name, 0.0) + time.perf_counter() - t0

    def _reset_worlds(self, idx: np.ndarray) -> None:
        """Reset worlds ``idx`` on the host as ``BinocularSaccadeEnv.reset`` does (their rngs continue):
        all at once where the scene's settled reset serves (``BatchedPlanner.take_settled``), else one by
        one through the scratch head."""
        seeds, places = [], []
        for i in idx:
            rng = self._rngs[i]
            if rng is None:
                self._rngs[i] = rng = seeding.np_random(None)[0]
            seed = core.head_seed(rng)  # as a world's head.reset(seed=...)
            if self._settled.usable:
                seeds.append(seed)
                places.append(self.task.placements(rng))
                continue
            self._settled.apply(self.head, seed)
            self.task.initialize_episode(self.head, rng)
            self.planner.take_reset(i)
        if self._settled.usable and len(idx):
            self.planner.take_settled(idx, self._settled, seeds, places)
        self._saccades[idx] = 0

    def _load(self, idx: np.ndarray) -> None:
        """Put the reset worlds ``idx`` on the device."""
        p = self.planner
        self.physics.load(idx, p.qpos[idx], p.qvel[idx], p.ctrl[idx], p.mocap_pos[idx], p.mocap_quat[idx])

    def _see(self) -> None:
        """Render both eyes of every world and see them: pinhole images pooled on the retina, or the
        retina rendered along its fields' rays; then the DPFT."""
        with self._part("render"):
            pictures = self.physics.render() if self.retina_rays is None else self.physics.render_retina()
        with self._part("retina"):
            if self.retina_rays is None:
                frame = self.vision.see(pictures, check_range=False)  # the renderer's floats lie in [0, 1]
            else:
                frame = self.vision.see_samples(pictures)
            self._frame = frame
        if self.timings is not None:  # the DPFT's share of that, timed once more on its own
            before = self.timings.get("dpft", 0.0)
            with self._part("dpft"):
                self.vision._frame(frame.samples)
            self.timings["retina"] -= self.timings["dpft"] - before

    def _cortical_now(self):
        assert self._frame is not None, "reset() sees the first frame"
        return self.vision.cortical(self._frame.periphery, self._template.cortex)

    @classmethod
    def _mask_info(cls, info: dict, mask: np.ndarray) -> dict:
        """A copy of a step's ``info`` whose ``_key`` masks are and-ed with ``mask`` (nested dicts too)."""
        out = {}
        for k, v in info.items():
            if k.startswith("_"):
                continue
            out[k] = cls._mask_info(v, mask) if isinstance(v, dict) else np.copy(v)
            out["_" + k] = info["_" + k] & mask
        return out

    def _observation(self) -> dict:
        torch = self._torch
        f, remapped = self._frame, self._remapped
        assert f is not None and remapped is not None, "reset() sees the first frame before any observation"
        obs = core.observation(
            self._cortical_now(),
            f.fovea.clamp(0.0, 1.0),
            remapped.clone(),
            torch.as_tensor(self.planner.eye_position_signal(), dtype=torch.float32, device=self.device),
            torch.view_as_real(f.coeffs).to(torch.float32) if self._template.include_coeffs else None,
        )
        if self.output == "numpy":
            obs = {k: v.cpu().numpy() for k, v in obs.items()}
        return obs

    def _decode(self, actions) -> tuple[np.ndarray, np.ndarray]:
        """Actions -> (N, 2) (horizontal, vertical) Fick increments (rad) and (N,) fixation-distance
        factors, with the single env's checks (the message names the world)."""
        if isinstance(actions, self._torch.Tensor):
            actions = actions.detach().cpu().numpy()
        env = self._template
        shape = self.action_space.shape
        assert shape is not None, "the env's action spaces (Box, MultiDiscrete) have a shape"
        return decode_actions(
            actions,
            shape,
            cells=env._cells,
            max_amplitude=env.max_amplitude,
            vergence=env.vergence,
            who="actions",
        )

    def _gaze_errors(self, plans, act: np.ndarray, active: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Both eyes' gaze errors (deg) to the task's target (N, 2) and the mean to each saccade's
        intended target (N,), from the device's camera poses (tasks._gaze_errors_deg, batched)."""
        ph = self.physics
        pos = ph.cam_xpos[:, self._cam_ids].double().cpu().numpy()  # (N, 2, 3)
        axis = -ph.cam_xmat[:, self._cam_ids, :, 2].double().cpu().numpy()  # the optical axis: camera -z
        n = self.num_envs
        intended = np.broadcast_to(self.planner.cyclopean_position, (n, 3)).copy()
        if plans is not None:
            intended[act] = plans.intended_target
        landing = np.where(active, gaze_errors(pos, axis, intended).mean(axis=1), 0.0)
        if self._target_gid is None:
            return np.zeros((n, 2)), landing
        return gaze_errors(pos, axis, ph.geom_xpos[:, self._target_gid].double().cpu().numpy()), landing
