"""N binocular heads in MuJoCo Warp: the eye servo driven by a controller kernel, both eyes
rendered by MJWarp's batch renderer (the physics and rendering half of
``envs.BatchedBinocularSaccade``).

One :class:`WarpHeads` holds ``mujoco_warp`` Model/Data for N worlds of one compiled head model
(``models.Head.model``) and a render context for the two eye cameras. Per env step the host
uploads each world's commanded eye angles at every millisecond (``models.SaccadePlan.angles``); the
plant's torques or the servo's set-points are computed from them on the device
(``models.servo_setpoints``, the CPU head's law, on torch tensors) and a Warp kernel writes them
into the controls before every physics step: on CUDA a step is captured once in a graph
(``chunk_ms`` physics steps per graph) and replayed. ``skip_solver=True`` steps without the constraint
solver and re-runs with it when a joint reaches its range. ``fused=True`` (the default on Warp's CPU
backend) steps a whole run in one kernel launch (``envs._warp_dynamics``), the joint limits included.

By design the physics steps at 1 ms throughout (the CPU head steps saccades at 0.25 ms) and the
feed-forward torque uses one constant inertia per joint; after the fixation the eyes rest on the
same endpoint (``tests/test_batched_env.py`` measures the difference). The solver rule and these
differences in full: docs/batched.md ("Batched env", section "The physics: WarpHeads").

Requires the ``gpu`` extra (``pip install -e ".[gpu]"``: mujoco-warp, warp-lang, torch).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

import models  # before mujoco_warp: models chooses MuJoCo's off-screen GL backend before mujoco loads
from models import linear_tail as _tail
from models import servo_setpoints
from models.render import EYES, HIDDEN_GEOM_GROUPS

__all__ = ["WarpHeads", "require_gpu_extra", "mujoco_replay", "TAIL_SETTLE_MS", "TAIL_CHUNK_MS", "FUSED_BLOCK_DIM"]

#: Milliseconds stepped past the last fast row of any world's command before the slow stretch may be
#: taken in closed form (the plant's short time constant and the eye's overshoot), and the stride of
#: the check that every eye has slowed (``models.linear_tail``).
TAIL_SETTLE_MS = 20
#: Steps of the closed form on one linear map: it is made again (after one exact step) this often.
TAIL_CHUNK_MS = 25
#: CUDA threads per block of the fused step (one thread per world): one warp, so that 4096 worlds make
#: 128 blocks spread over a GPU's ~130 multiprocessors, where Warp's default of 256 would keep them on
#: 16 (the kernel is bound by each thread's serial latency, not by throughput). Unmeasured on a GPU.
FUSED_BLOCK_DIM = 32


def require_gpu_extra():
    """Import and return (warp, mujoco_warp, torch), or raise ImportError saying how to install them."""
    try:
        import mujoco_warp as mjw
        import torch
        import warp as wp
    except ImportError as e:
        raise ImportError(
            f'the batched env needs the gpu extra ({e.name} is missing): pip install -e ".[gpu]" '
            "(mujoco-warp, warp-lang, torch; on a machine without CUDA, torch's CPU build serves)"
        ) from None
    wp.config.quiet = True
    return wp, mjw, torch


def mujoco_replay(head: models.Head, qpos, qvel, ctrl, table: np.ndarray, lengths, n_ms: int) -> np.ndarray:
    """A run of :class:`WarpHeads` stepped again by MuJoCo's C ``mj_step`` in float64 (the reference the
    batched physics is measured against): from each world's joints, velocities and controls (one row per
    world), the set-point table's row ``min(t, lengths[w] - 1)`` written into the eye actuators' controls
    before millisecond t, as the ``servo`` kernel writes them (``table``: :meth:`WarpHeads.setpoints`, in
    the precision the device holds it). Returns the joint angles after ``n_ms`` ms, (N, nq)."""
    import mujoco

    mjm = head.model
    pos0, vel0, ff0 = (int(a[0]) for a in head.eye_actuator_ids)
    d = mujoco.MjData(mjm)
    out = np.empty((len(qpos), mjm.nq))
    for w in range(len(qpos)):
        mujoco.mj_resetData(mjm, d)
        d.qpos[:], d.qvel[:], d.ctrl[:] = qpos[w], qvel[w], ctrl[w]
        for t in range(int(n_ms)):
            r = table[w, min(t, int(lengths[w]) - 1)]
            d.ctrl[pos0 : pos0 + 6], d.ctrl[vel0 : vel0 + 6], d.ctrl[ff0 : ff0 + 6] = r[:6], r[6:12], r[12:18]
            mujoco.mj_step(mjm, d)
        out[w] = d.qpos
    return out


def _solver_skippable(mjm, limited: np.ndarray) -> bool:
    """Whether the model's only possible constraints are its joints' limits, tested by
    ``beyond_range`` (hinges and slides with no margin), and its integrator is implicit in velocity
    (the unconstrained step of ``WarpHeads`` integrates as ``mujoco_warp.implicit``)."""
    import mujoco

    contacts_off = bool(mjm.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT)
    return bool(
        mjm.opt.integrator in (mujoco.mjtIntegrator.mjINT_IMPLICITFAST, mujoco.mjtIntegrator.mjINT_IMPLICIT)
        and contacts_off
        and mjm.neq == 0
        and mjm.nflex == 0
        and mjm.nsensor == 0
        and not np.any(mjm.dof_frictionloss)
        and not np.any(mjm.tendon_limited)
        and not np.any(mjm.tendon_frictionloss)
        and not np.any(mjm.jnt_margin[limited])
        and np.all(np.isin(mjm.jnt_type[limited], (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE)))
    )


class WarpHeads:
    """N worlds of one head model in MuJoCo Warp, stepped by the saccade controller and rendered.

    Args:
        head: a ``models.Head`` whose compiled model (scene, image size, field of view) the worlds share.
        num_worlds: N.
        device: a Warp/torch device name (``"cuda"``, ``"cuda:1"``, ``"cpu"``).
        chunk_ms: physics steps per captured CUDA graph (a step runs whole graphs, so up to
            ``chunk_ms - 1`` extra milliseconds of settled fixation; unused on the CPU).
        retina_directions: None (render pinhole images, :meth:`render`) or the retina's ray directions
            (s^2, P, 3) (``envs.retina_rays.field_ray_directions``): render the samples themselves
            (:meth:`render_retina`) instead of images.
        skip_solver: step without MuJoCo's constraint solver while no limited joint reaches its range,
            stepping a run again with the solver where one does (see the module docstring); False:
            MuJoCo Warp's ``step`` throughout; None (default): True on the CPU backend, False on CUDA.
        linear_tail: take each run's slow stretch in closed form (``models.linear_tail``'s map of the
            ``implicitfast`` step, on this device; see the module docstring); False steps every
            millisecond; None (default): True on the CPU backend where the run is not fused, False
            on CUDA until it is measured there.
        fused: step a whole run in one Warp kernel launch (``envs._warp_dynamics``: MuJoCo's
            ``implicitfast`` step for a tree of hinges with its joint limits, one thread per world,
            float64) instead of MuJoCo Warp's ~50 launches per millisecond, every millisecond (no closed
            form). None (default): on the CPU backend where the model is one it covers (``tree_model``)
            and neither ``skip_solver=False`` nor ``linear_tail=True`` was asked for; off on CUDA until
            measured there.
    """

    def __init__(
        self,
        head: models.Head,
        num_worlds: int,
        device: str = "cuda",
        *,
        chunk_ms: int = 25,
        retina_directions: np.ndarray | None = None,
        skip_solver: bool | None = None,
        linear_tail: bool | None = None,
        fused: bool | None = None,
    ) -> None:
        wp, mjw, torch = require_gpu_extra()
        self._wp, self._mjw, self._torch = wp, mjw, torch
        self.device = wp.get_device(device)
        self.torch_device = torch.device(str(self.device) if self.device.is_cuda else "cpu")
        mjm = head.model
        self.num_worlds = n = int(num_worlds)
        self.image_shape = head.image_shape
        self.chunk_ms = int(chunk_ms)
        self._qadr, self._vadr = head.eye_joint_addresses
        acts = head.eye_actuator_ids
        self._pos0, self._vel0, self._ff0 = (int(a[0]) for a in acts)
        for a, a0 in zip(acts, (self._pos0, self._vel0, self._ff0)):
            if not np.array_equal(a, np.arange(a0, a0 + 6)):
                raise ValueError("the head model's eye actuators are not contiguous (pos, vel, ff of 6 joints each)")
        M = np.zeros((mjm.nv, mjm.nv))
        import mujoco

        mujoco.mj_fullM(mjm, head.data, M)
        Mee = M[np.ix_(self._vadr, self._vadr)]
        # the feed-forward uses one inertia for every eye joint: the eyeball's (isotropic) inertia plus
        # armature, the mass matrix's diagonal at primary position; the gimbal's coupling away from it
        # (off-diagonal terms ~ I sin(elevation)) is left to the servo, as the CPU head leaves the
        # change of M over a saccade
        self._inertia = float(np.mean(np.diag(Mee)))
        # the orbital plant (``models.plant``): the command's inertia, stiffness and damping, the CPU head's
        self._plant = head.plant_command
        self._dt = float(mjm.opt.timestep)
        if abs(self._dt - 1e-3) > 1e-12:
            raise ValueError(f"the batched physics steps 1 ms; the model's timestep is {self._dt}")
        from ._warp_kernels import advance, affine_run, beyond_range, servo

        self._servo, self._advance, self._beyond_range = servo, advance, beyond_range
        self._affine_run = affine_run
        limited = np.flatnonzero(mjm.jnt_limited)
        for name, flag in (("skip_solver", skip_solver), ("linear_tail", linear_tail), ("fused", fused)):
            if flag is not None and not isinstance(flag, (bool, np.bool_)):
                raise TypeError(f"{name} must be True, False or None; got {flag!r}")
        skip_solver, linear_tail, fused = (None if f is None else bool(f) for f in (skip_solver, linear_tail, fused))
        self._tree = self._fused_tree(mjm, fused, skip_solver, linear_tail, _solver_skippable(mjm, limited))
        #: each run stepped in one kernel launch (``envs._warp_dynamics``)
        self.fused = self._tree is not None
        if self.fused:  # the limits in the kernel; a run whose limits' active set did not settle re-runs
            skip_solver, linear_tail = True, False
        if skip_solver is None:
            skip_solver = not self.device.is_cuda
        self.skip_solver = bool(skip_solver) and _solver_skippable(mjm, limited)
        self.cam_ids = [mjm.camera(e).id for e in EYES]
        groups = [g for g in range(6) if g not in HIDDEN_GEOM_GROUPS]
        h, w = self.image_shape
        with wp.ScopedDevice(self.device):
            self.model = mjw.put_model(mjm)
            self.data = mjw.make_data(mjm, nworld=n)
            if retina_directions is None:
                self.render_context = mjw.create_render_context(
                    mjm,
                    nworld=n,
                    cam_res=(w, h),
                    render_rgb=True,
                    render_depth=False,
                    use_textures=True,
                    use_shadows=False,
                    enabled_geom_groups=groups,
                    cam_active=self.cam_ids,
                )
                self._rgb = [wp.zeros((n, h, w), dtype=wp.vec3f) for _ in EYES]
                self.retina = None
            else:
                from .retina_rays import RetinaRenderContext

                self.retina = RetinaRenderContext(mjm, n, self.cam_ids, retina_directions, groups)
            self._step = wp.zeros(1, dtype=wp.int32)
            self._ncmd = wp.ones(n, dtype=wp.int32)
            self._cmd = wp.zeros((n, 2, 18), dtype=wp.float32)
            self._limit_adr = wp.array(mjm.jnt_qposadr[limited].astype(np.int32), dtype=wp.int32)
            self._limit_lo = wp.array(mjm.jnt_range[limited, 0].astype(np.float32), dtype=wp.float32)
            self._limit_hi = wp.array(mjm.jnt_range[limited, 1].astype(np.float32), dtype=wp.float32)
            self._left = wp.zeros(1, dtype=wp.int32)
            d = self.data
            # the run's starting state, to step it again with the solver where a joint reached its range
            self._saved = [(a, wp.empty_like(a)) for a in (d.qpos, d.qvel, d.act, d.qacc_warmstart, d.time)]
            # the closed form's starting state, to step only that stretch again where a joint would reach
            # its range in it (the stepped part before it already ran with the solver, or unflagged)
            self._tail_saved = [(a, wp.empty_like(a)) for a, _ in self._saved]
            self._tail_left = wp.zeros(1, dtype=wp.int32)
            if self.fused:
                from ._warp_dynamics import run_tree, scratch

                self._run_tree = run_tree
                self._scratch = scratch(n, mjm.nv, self._tree.parent.shape[0], len(limited), self.device)
        # the same arrays seen with no room for constraints: MuJoCo Warp's solve() then sets qacc to
        # qacc_smooth, and qacc_smooth is computed (both need njmax == 0)
        self._free_data = dataclasses.replace(self.data, njmax=0)
        # and the model with its constraints switched off (no limit rows are made)
        self._free_model = dataclasses.replace(
            self.model,
            opt=dataclasses.replace(
                self.model.opt, disableflags=int(self.model.opt.disableflags) | int(mjw.DisableBit.CONSTRAINT)
            ),
        )
        self._stepped = 0
        t = wp.to_torch
        d = self.data
        self.qpos, self.qvel, self.ctrl = t(d.qpos), t(d.qvel), t(d.ctrl)
        self.mocap_pos, self.mocap_quat = t(d.mocap_pos), t(d.mocap_quat)
        self.cam_xpos, self.cam_xmat = t(d.cam_xpos), t(d.cam_xmat)
        self.geom_xpos = t(d.geom_xpos)
        self._eye_q = torch.as_tensor(np.asarray(self._qadr), device=self.torch_device)
        self._graph = None
        # the slow stretch in closed form (models.linear_tail): the linear forces, the mass matrix's
        # sparse layout (MuJoCo's lower-triangle rows, as MuJoCo Warp stores ``M``) and the eye joints
        if linear_tail is None:  # (checked above)
            linear_tail = not self.device.is_cuda
        forces = _tail.linear_forces(mjm) if linear_tail else None
        self.linear_tail = forces is not None
        self._pending: tuple[int, int] | None = None
        self._tail_ran = False
        self._tail_start = 0
        #: runs stepped again with the solver: whole (a joint reached its range in a solver-free step) and
        #: from the closed form's start only (a joint would have reached it in the closed form)
        self.reruns = {"whole": 0, "closed_form": 0}
        #: milliseconds of physics taken in closed form so far (the rest were stepped)
        self.closed_form_ms = 0
        if forces is not None:
            dev64 = {"dtype": torch.float64, "device": self.torch_device}
            self._forces = tuple(torch.as_tensor(a, **dev64) for a in forces)
            rows = np.repeat(np.arange(mjm.nv), mjm.M_rownnz)
            self._m_rows = torch.as_tensor(rows, device=self.torch_device)
            self._m_cols = torch.as_tensor(mjm.M_colind.astype(np.int64), device=self.torch_device)
            eye = np.zeros(mjm.nv, bool)
            eye[np.asarray(self._vadr)] = True
            self._eye_dof = torch.as_tensor(eye, device=self.torch_device)
            with wp.ScopedDevice(self.device):
                self._lim_adr_wp = wp.array(mjm.jnt_qposadr[limited].astype(np.int32), dtype=wp.int32)
                self._lim_lo_wp = wp.array(mjm.jnt_range[limited, 0], dtype=wp.float64)
                self._lim_hi_wp = wp.array(mjm.jnt_range[limited, 1], dtype=wp.float64)
            self._ctrl_cols = torch.as_tensor(
                np.concatenate([np.arange(a, a + 6) for a in (self._pos0, self._vel0, self._ff0)]),
                device=self.torch_device,
            )

    def _fused_tree(self, mjm, fused, skip_solver, linear_tail, skippable: bool):
        """The fused step's model (``envs._warp_dynamics.tree_model``), or None where the run is not fused
        (``fused`` in the class docstring); a ValueError where ``fused=True`` cannot be honoured. The
        flags are None or bools (checked by the caller)."""
        asked = fused is True
        if fused is None:
            fused = not self.device.is_cuda and skip_solver is not False and linear_tail is not True
        if not fused:
            return None
        if skip_solver is False or linear_tail is True:
            raise ValueError(
                "fused=True steps every millisecond in its own kernel, the joint limits included, not with "
                "MuJoCo Warp's solver: it cannot be combined with skip_solver=False or linear_tail=True "
                "(leave those None)"
            )
        from ._warp_dynamics import tree_model

        tree = tree_model(mjm, self.device) if skippable else None
        if tree is None and asked:
            raise ValueError(
                "fused=True: this model is not one the fused step covers (hinge joints only, affine joint "
                "actuators, no contacts, tendons, equalities, sensors or fluid; implicitfast; the full list: "
                "envs._warp_dynamics.tree_model); pass fused=False or None"
            )
        return tree

    # ------------------------------------------------------------------ state
    def load(self, worlds: np.ndarray, qpos, qvel, ctrl, mocap_pos, mocap_quat) -> None:
        """Set ``worlds``' joints, velocities, set-points and movable bodies (arrays with one row per world,
        as ``models.Head.data`` holds them) and recompute their kinematics."""
        torch = self._torch
        idx = torch.as_tensor(np.asarray(worlds, np.int64), device=self.torch_device)
        dev = self.torch_device

        def put(dst, array):
            dst[idx] = torch.as_tensor(np.asarray(array), dtype=dst.dtype, device=dev)

        self._handoff_to_torch()  # Warp's last writes land before torch's
        put(self.qpos, qpos)
        put(self.qvel, qvel)
        put(self.ctrl, ctrl)
        if self.mocap_pos.shape[1]:
            put(self.mocap_pos, mocap_pos)
            put(self.mocap_quat, mocap_quat)
        if self.device.is_cuda:  # torch's writes (its stream) land before Warp's next kernels (its stream)
            self._torch.cuda.synchronize(self.torch_device)
        self.forward()

    def forward(self) -> None:
        with self._wp.ScopedDevice(self.device):
            self._mjw.forward(self.model, self.data)
        self._handoff_to_torch()

    def _handoff_to_torch(self) -> None:
        """Warp and torch run on different CUDA streams: wait for Warp's work before torch reads (or
        overwrites) the arrays they share (a no-op on the CPU, where launches are synchronous)."""
        if self.device.is_cuda:
            self._wp.synchronize_device(self.device)

    def eye_qpos(self):
        """Both eyes' joint angles, (N, 2, 3) float32 on the device."""
        return self.qpos[:, self._eye_q].reshape(-1, 2, 3)

    # ------------------------------------------------------------------ physics
    def setpoints(self, commands: np.ndarray, lengths: np.ndarray, out=None):
        """The servo's set-points (N, T, 18) of the command tables (N, T, 6) (``models.servo_setpoints``
        at 1 ms, with each world's endpoint at its row ``lengths[w] - 1``: its hold rule, the CPU head's),
        computed on this device in float64 (the host's numbers): a new float64 tensor, or written into
        ``out`` (N, T, 18) in its dtype. Only the commanded angles travel to the device, a third of the table."""
        torch, dev = self._torch, self.torch_device
        q = torch.as_tensor(np.asarray(commands, np.float64), device=dev)
        T = q.shape[1]
        ext = torch.cat([q[:, :1], q, q[:, -1:]], dim=1)  # at rest before the first row, held after the last
        dt = torch.full((T + 1,), self._dt, dtype=torch.float64, device=dev)
        ends = torch.as_tensor(np.asarray(lengths, np.int64), device=dev)
        if out is None:
            out = torch.empty((q.shape[0], T, 18), dtype=torch.float64, device=dev)
        if self._plant is None:
            return servo_setpoints(
                ext, dt, self._inertia * torch.eye(6, dtype=torch.float64, device=dev), out, end=ends
            )
        I, K, B = (torch.as_tensor(a, dtype=torch.float64, device=dev) for a in self._plant)
        return servo_setpoints(ext, dt, I, out, stiffness=K, damping=B, end=ends)  # ext[ends] = q[ends - 1]

    def run(self, commands: np.ndarray, lengths: np.ndarray, n_ms: int, *, wait: bool = True) -> int:
        """Step every world ``n_ms`` ms (on CUDA, unfused: rounded up to whole ``chunk_ms``) following ``commands``
        (N, T, 6): world w's commanded angles at 0, 1, ... ``lengths[w] - 1`` ms from now, then held at
        the last (the command at rest before them). The set-points are ``models.servo_setpoints``'
        (the CPU head's servo law) at 1 ms steps with one inertia per joint. Returns the ms stepped.

        ``wait=False``: return once the steps are launched (the host's arrays ``commands`` and
        ``lengths`` are on the device by then and may be reused); the host can work meanwhile, and
        :meth:`wait` must be called before torch reads the device's state. On Warp's CPU backend every
        launch runs to its end before it returns: the same either way."""
        wp, mjw = self._wp, self._mjw
        n, T = commands.shape[:2]
        with wp.ScopedDevice(self.device):
            if self._cmd.shape[1] < T:  # grown with headroom: each growth means a new graph
                rows = 64 * math.ceil(max(T, 1.5 * self._cmd.shape[1]) / 64)
                self._cmd = wp.zeros((n, rows, 18), dtype=wp.float32)
                self._graph = None  # the graph captured the old table
                self._handoff_to_torch()  # Warp's zeroing (its stream) lands before torch writes the table
            # only the rows in use travel (the kernel never reads a world's rows past lengths[w] - 1)
            self.setpoints(commands, lengths, out=wp.to_torch(self._cmd)[:, :T])
            self._ncmd.assign(np.asarray(lengths, np.int32))
            if self.device.is_cuda:  # torch's copy (its stream) lands before Warp's kernels (Warp's stream)
                self._torch.cuda.synchronize(self.torch_device)
            self._step.zero_()
            self._left.zero_()
            for a, saved in self._saved:
                wp.copy(saved, a)
            total, n_ms = n_ms, self._stepped_prefix(T, n_ms)
            self._pending = (n_ms, total) if total > n_ms else None
            stepped = 0
            if self.fused:
                d = self.data
                wp.launch(
                    self._run_tree,
                    dim=n,
                    inputs=[self._tree, self._scratch, d.qpos, d.qvel, d.ctrl, d.time, self._cmd, self._ncmd, 0, n_ms]
                    + [self._pos0, self._vel0, self._ff0],
                    outputs=[self._left],
                    block_dim=FUSED_BLOCK_DIM,
                )
                self._step.fill_(n_ms)
                stepped = n_ms
            elif self.device.is_cuda and self._graph is not False:
                chunks = max(1, math.ceil(n_ms / self.chunk_ms))
                todo = chunks
                if self._graph is None:
                    # the first chunk runs uncaptured (Warp loads its modules on first launch, which a
                    # capture does not allow), then the same launches are captured for the rest
                    for _ in range(self.chunk_ms):
                        self._physics_step()
                    stepped, todo = self.chunk_ms, todo - 1
                    self._graph = self._capture()
                if self._graph is not False:
                    for _ in range(todo):
                        wp.capture_launch(self._graph)
                    stepped = chunks * self.chunk_ms
            for _ in range(stepped, n_ms):  # the CPU backend; CUDA where no graph could be captured
                self._physics_step()
            self._stepped = stepped = max(stepped, n_ms)
            if self._pending is not None:
                self._pending = (stepped, self._pending[1])
                if stepped >= self._pending[1]:
                    self._pending = None
            if self._pending is None:
                mjw.forward(self.model, self.data)
        done = stepped if self._pending is None else total
        if wait:
            self.wait()
        return done

    def wait(self) -> None:
        """Wait for the physics launched by ``run(..., wait=False)`` before torch reads its state (and
        step the run again with the solver if a joint reached its range)."""
        self._handoff_to_torch()
        if self._pending is not None:
            self._run_tail(*self._pending)
            self._pending = None
        if self._stepped and self.skip_solver and int(self._left.numpy()[0]):
            self._rerun_with_solver()
        elif self._tail_ran and int(self._tail_left.numpy()[0]):
            self._rerun_closed_form_with_solver()
        self._tail_ran = False

    # ------------------------------------------------------------------ the slow stretch in closed form
    def _stepped_prefix(self, T: int, n_ms: int) -> int:
        """How many of a run's ``n_ms`` milliseconds to step before its slow stretch may be taken in
        closed form: to :data:`TAIL_SETTLE_MS` past the last row of any world's command table whose
        commanded speed is :data:`models.linear_tail.LINEAR_SPEED_DEG_S` or more (the saccade and any
        fast vergence); ``n_ms`` when too little would be left."""
        if not self.linear_tail:
            return n_ms
        torch = self._torch
        speed = self._torch_cmd()[:, :T, 6:12].abs().amax(dim=(0, 2))  # (T,) rad/s, fastest world
        fast = torch.nonzero(speed >= math.radians(_tail.LINEAR_SPEED_DEG_S))
        start = (int(fast[-1, 0]) + 1 if len(fast) else 0) + TAIL_SETTLE_MS
        return n_ms if n_ms - start < _tail.MIN_STEPS else start

    def _torch_cmd(self):
        return self._wp.to_torch(self._cmd)

    def _slow(self) -> bool:
        """Whether every world's eyes are slower than ``LINEAR_SPEED_DEG_S`` and its neck at rest."""
        return _tail.slow_enough(self.qvel, self._eye_dof)

    def _run_tail(self, t: int, total: int) -> None:
        """Milliseconds ``t`` to ``total`` of the run: stepped until every world is slow, then in closed form."""
        wp, mjw = self._wp, self._mjw
        with wp.ScopedDevice(self.device):
            self._handoff_to_torch()
            while total - t >= _tail.MIN_STEPS and not self._slow():
                for _ in range(min(TAIL_SETTLE_MS, total - t)):
                    self._physics_step()
                    t += 1
                self._handoff_to_torch()
            if total - t >= _tail.MIN_STEPS:
                self._tail_ran, self._tail_start = True, t
                for a, saved in self._tail_saved:
                    wp.copy(saved, a)
                self._tail_left.zero_()
                self._closed_form(t, total)
                self.closed_form_ms += total - t
            else:
                for _ in range(total - t):
                    self._physics_step()
            self._stepped = total
            mjw.forward(self.model, self.data)
        self._handoff_to_torch()

    def _closed_form(self, t: int, total: int) -> None:
        """Every world from ms ``t`` to ``total`` by the ``implicitfast`` step's linear map
        (``models.linear_tail.step_matrices`` with each world's mass matrix), made again every
        :data:`TAIL_CHUNK_MS` after one exact step; flags ``_tail_left`` where a limited joint would reach its
        range (``wait`` then steps this stretch again with the solver)."""
        torch, wp = self._torch, self._wp
        n, nv, dt = self.num_worlds, self.qpos.shape[1], self._dt
        K, D, G = self._forces
        cols = self._ctrl_cols
        table = self._torch_cmd()
        last = wp.to_torch(self._ncmd).long()[:, None] - 1
        worlds = torch.arange(n, device=self.torch_device)[:, None]
        mflat = wp.to_torch(self.data.M)
        time = wp.to_torch(self.data.time)
        while t < total:
            x0 = torch.cat([self.qpos, self.qvel], 1).double()
            self._sync_torch_to_warp()
            self._physics_step()  # the exact step t: x1, with the mass matrix at x0 in data.M
            self._handoff_to_torch()
            u0 = self.ctrl[:, cols].double()
            x = torch.cat([self.qpos, self.qvel], 1).double()
            t += 1
            k = min(TAIL_CHUNK_MS, total - t)
            if k == 0:
                break
            M = torch.zeros((n, nv, nv), dtype=torch.float64, device=self.torch_device)
            M[:, self._m_rows, self._m_cols] = mflat.double()
            M = M + M.transpose(1, 2) - torch.diag_embed(torch.diagonal(M, dim1=1, dim2=2))
            A, B = _tail.step_matrices(M, K, D, G, dt)
            rows = torch.minimum(torch.arange(t, t + k, device=self.torch_device)[None], last)  # (n, k)
            U = table[worlds, rows].double()  # (n, k, 18): pos, vel, ff set-points = ctrl[cols]
            # x_(j+1) = x1 + A (x_j - x0) + B (u_j - u0)
            W = (U - u0[:, None]) @ B[:, :, cols].transpose(1, 2) + (x - (A @ x0[..., None])[..., 0])[:, None]
            xw, yw = wp.from_torch(x.contiguous()), wp.empty((n, 2 * nv), dtype=wp.float64)
            self._sync_torch_to_warp()
            wp.launch(
                self._affine_run,
                dim=n,
                inputs=[wp.from_torch(A.contiguous()), wp.from_torch(W.contiguous()), xw, yw]
                + [self._lim_adr_wp, self._lim_lo_wp, self._lim_hi_wp],
                outputs=[self._tail_left],
            )
            self._handoff_to_torch()
            x = wp.to_torch(xw)
            self.qpos.copy_(x[:, :nv])
            self.qvel.copy_(x[:, nv:])
            self.ctrl[:, cols] = U[:, -1].to(self.ctrl.dtype)
            time += k * dt
            t += k
            self._step.fill_(t)
        self._sync_torch_to_warp()

    def _sync_torch_to_warp(self) -> None:
        """torch's writes (its stream) land before Warp's next kernels (Warp's stream); a no-op on the CPU."""
        if self.device.is_cuda:
            self._torch.cuda.synchronize(self.torch_device)

    def _rerun_with_solver(self) -> None:
        """Step the last run again from its start with MuJoCo Warp's full ``step`` (the constraint
        solver), launch by launch: a joint reached its range, where the limit's constraint acts."""
        wp, mjw = self._wp, self._mjw
        with wp.ScopedDevice(self.device):
            for a, saved in self._saved:
                wp.copy(a, saved)
            self._step.zero_()
            for _ in range(self._stepped):
                self._physics_step(solver=True)
            mjw.forward(self.model, self.data)
        self._stepped = 0
        self.reruns["whole"] += 1
        self._handoff_to_torch()

    def _rerun_closed_form_with_solver(self) -> None:
        """Step the closed form's stretch again from its starting state with MuJoCo Warp's full ``step``:
        a limited joint would have reached its range in it, where the limit's constraint acts. What was
        stepped before it stands (it ran with the solver, or a solver-free step that reached a range
        sent the whole run back). On CUDA the captured graph (``chunk_ms`` steps) is replayed where it
        steps with the solver; the milliseconds past its last whole chunk are launched one by one."""
        wp, mjw = self._wp, self._mjw
        t0, total = self._tail_start, self._stepped
        with wp.ScopedDevice(self.device):
            for a, saved in self._tail_saved:
                wp.copy(a, saved)
            self._step.fill_(t0)
            k = total - t0
            if self._graph not in (None, False) and not self.skip_solver:
                for _ in range(k // self.chunk_ms):
                    wp.capture_launch(self._graph)
                k %= self.chunk_ms
            for _ in range(k):
                self._physics_step(solver=True)
            mjw.forward(self.model, self.data)
        self.reruns["closed_form"] += 1
        self._handoff_to_torch()

    def _capture(self):
        """Capture ``chunk_ms`` physics steps in a CUDA graph, or return False (and warn once) where the
        driver cannot: MJWarp's solver loops with conditional graph nodes (``wp.capture_while``), which
        need CUDA 12.4+ drivers; without a graph the same launches run one by one (slower, same result)."""
        wp = self._wp
        reason = None
        if hasattr(wp, "is_conditional_graph_supported") and not wp.is_conditional_graph_supported():
            reason = "this CUDA driver/toolkit has no conditional graph nodes"
        else:
            try:
                with wp.ScopedCapture() as cap:
                    for _ in range(self.chunk_ms):
                        self._physics_step()
                return cap.graph
            except Exception as e:  # noqa: BLE001 - any capture failure: run uncaptured
                reason = f"{type(e).__name__}: {e}"
        import warnings

        warnings.warn(
            f"the batched physics runs without a CUDA graph ({reason}); each physics step is launched "
            "from Python (slower, same result)",
            RuntimeWarning,
            stacklevel=3,
        )
        return False

    def _physics_step(self, solver: bool = False) -> None:
        wp, mjw = self._wp, self._mjw
        wp.launch(
            self._servo,
            dim=(self.num_worlds, 6),
            inputs=[self._cmd, self._ncmd, self._step, self._pos0, self._vel0, self._ff0],
            outputs=[self.data.ctrl],
        )
        if solver or not self.skip_solver:
            mjw.step(self.model, self.data)
        else:
            self._unconstrained_step()
        wp.launch(self._advance, dim=1, inputs=[self._step])

    def _unconstrained_step(self) -> None:
        """``mujoco_warp.step`` with no constraint (MuJoCo's ``mj_step``: forward dynamics, then the
        implicit-in-velocity integrator) for a model with no contacts and no joint at its range: the
        constraint forces are zero, so ``qacc = qacc_smooth`` and ``M qacc`` (the integrator's ``efc.Ma``)
        is ``qfrc_smooth``. Sensors (the head has none) and the energy are not computed. Flags
        ``_left`` where a limited joint ends the step at or beyond its range."""
        wp, mjw, m, d = self._wp, self._mjw, self._free_model, self._free_data
        mjw.fwd_position(m, d, factorize=False)
        mjw.fwd_velocity(m, d)
        mjw.fwd_actuation(m, d)
        mjw.fwd_acceleration(m, d, factorize=True)
        wp.copy(d.qacc, d.qacc_smooth)
        wp.copy(d.efc.Ma, d.qfrc_smooth)
        mjw.implicit(m, d)
        if self._limit_adr.shape[0]:
            wp.launch(
                self._beyond_range,
                dim=(self.num_worlds, self._limit_adr.shape[0]),
                inputs=[d.qpos, self._limit_adr, self._limit_lo, self._limit_hi],
                outputs=[self._left],
            )

    # ------------------------------------------------------------------ rendering
    def render_retina(self):
        """Both eyes' retina samples rendered along the receptive fields' rays, (N, 2, P, 3) float32 in
        [0, 1] on the device (``envs.retina_rays``)."""
        with self._wp.ScopedDevice(self.device):
            out = self.retina.render(self.model, self.data)
        self._handoff_to_torch()
        return out

    def render(self):
        """Both eyes' images of every world, (N, 2, H, W, 3) float32 in [0, 1] on the device (row 0 at the
        top, as ``models.Head.render``)."""
        wp, mjw, torch = self._wp, self._mjw, self._torch
        with wp.ScopedDevice(self.device):
            mjw.refit_bvh(self.model, self.data, self.render_context)
            mjw.render(self.model, self.data, self.render_context)
            for i, out in enumerate(self._rgb):
                mjw.get_rgb(self.render_context, i, out)
        self._handoff_to_torch()
        return torch.stack([wp.to_torch(a) for a in self._rgb], dim=1)
