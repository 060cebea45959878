"""The eyes' slow settle in closed form: the physics' one-step map, linear once the eyes are slow,
iterated in a compiled loop instead of stepping MuJoCo millisecond by millisecond.

After a saccade the eye plant settles through its slow tail (the vergence generator's ``(1 + s)
e^-s`` and the plant's elastic time constant, up to ~1 s) and then holds: hundreds of physics steps
whose only nonlinearities are the gimbal's inertia, which changes with the eye's posture, and its
velocity products. For joints driven by springs, dampers and affine joint actuators, MuJoCo's
``implicitfast`` step is ``v' = v + dt (M + dt D)^-1 (G u - K q - D v + c)``, ``q' = q + dt v'``
(:func:`step_matrices`: ``M`` the mass matrix with armature, ``K`` and ``D`` the joints' stiffness and
damping plus the actuators' position and velocity feedback, ``G`` the actuators' gains, ``c`` what
does not depend on the state). With ``M`` held at the current posture this is the affine map
``x' = x1 + A (x - x0) + B (u - u0)`` of the state ``x = (qpos, qvel)`` and the controls ``u``, ``x1``
the exact step from ``x0``. :class:`LinearTail` takes a stretch that way once every eye joint is slower
than :data:`LINEAR_SPEED_DEG_S` and makes the map again wherever an eye has moved
:data:`LINEAR_STRIDE_DEG`; the batched engine (``envs.batched_physics``) uses the same matrices on
its device.

Accuracy (``tests/test_linear_tail.py``: 60 random binocular gaze shifts near and far, plant and servo
drives, each against stepping the same controls): eye angles within 1e-4 deg of the stepped physics.
``A`` and ``B`` agree with MuJoCo's finite-differenced ``mujoco.mjd_transitionFD`` (``B`` to 1e-9;
``A`` but for the velocity products, which ``implicitfast`` itself leaves out of its implicit part).
Where the map would take a limited joint to its range (where MuJoCo's constraint solver acts) or
another joint (the neck) is moving, nothing is changed and the caller steps the physics instead.
Cost: ~20 us per map plus ~0.1 us per step, so only stretches of at least :data:`MIN_STEPS` steps are
taken in closed form.
"""

from __future__ import annotations

import math
from typing import Any

import numba as nb
import numpy as np

from conformal.kernels import DISK_CACHE

from ._gl import mujoco

__all__ = [
    "LinearTail",
    "LINEAR_SPEED_DEG_S",
    "LINEAR_STRIDE_DEG",
    "MIN_STEPS",
    "linear_forces",
    "slow_enough",
    "step_matrices",
]

#: Eye speed (deg/s, every eye joint) below which a step is taken as linear: at 10-20 deg/s the
#: velocity products give up to 1e-4 deg over a 600 ms tail, at 6 deg/s ~1e-5 deg (measured).
LINEAR_SPEED_DEG_S = 10.0
#: Speed (deg/s) below which the head's other joints count as at rest.
REST_SPEED_DEG_S = 1.0
#: How far (deg) an eye joint may move on one linearisation before it is made again where the eye
#: is: the gimbal's inertia changes with the eye's posture (a pulse 30 % too large drifts degrees).
LINEAR_STRIDE_DEG = 0.5
#: The shortest stretch (physics steps) the batched engine takes in closed form (a map costs a few
#: physics steps there).
MIN_STEPS = 20


def slow_enough(qvel: Any, eye: Any) -> bool:
    """Whether a state is slow enough for the linear map: every eye joint slower than
    :data:`LINEAR_SPEED_DEG_S` and every other joint than :data:`REST_SPEED_DEG_S`. ``qvel``: joint
    velocities (rad/s), ``(nv,)`` or ``(worlds, nv)``, numpy or torch; ``eye``: the eye joints' boolean
    mask ``(nv,)`` in the same library. The one test of both engines."""
    v = abs(qvel)
    if not bool(v[..., eye].max() < math.radians(LINEAR_SPEED_DEG_S)):
        return False
    other = v[..., ~eye]
    return other.shape[-1] == 0 or bool(other.max() < math.radians(REST_SPEED_DEG_S))


def linear_forces(model) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """``(K, D, G)``: the joints' stiffness and damping plus the actuators' position and velocity
    feedback, each (nv,), and the actuators' gains (nv, nu), so that the joint forces are
    ``G u - K q - D v`` plus terms that do not depend on the state (gravity, springs' rest positions,
    the actuators' offsets); None where a model's forces are not of that form (an actuator that is not
    an affine one on a hinge or slide, tendons, equality constraints, contacts, activations, an
    integrator other than ``implicitfast``, a ball or free joint)."""
    import mujoco

    joint_kinds = (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE)
    if (
        model.opt.integrator != mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        or model.nq != model.nv
        or model.na
        or model.ntendon
        or model.neq
        or not (model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT)
        or not np.all(np.isin(model.jnt_type, joint_kinds))
        or np.any(model.actuator_trntype != mujoco.mjtTrn.mjTRN_JOINT)
        or np.any(model.actuator_dyntype != mujoco.mjtDyn.mjDYN_NONE)
        or np.any(model.actuator_gaintype != mujoco.mjtGain.mjGAIN_FIXED)
        or not np.all(np.isin(model.actuator_biastype, (mujoco.mjtBias.mjBIAS_NONE, mujoco.mjtBias.mjBIAS_AFFINE)))
        or np.any(model.dof_frictionloss)
    ):
        return None
    nv = model.nv
    K, D, G = np.zeros(nv), model.dof_damping.copy(), np.zeros((nv, model.nu))
    K[model.jnt_dofadr] += model.jnt_stiffness
    dof = model.jnt_dofadr[model.actuator_trnid[:, 0]]
    gear = model.actuator_gear[:, 0]
    affine = model.actuator_biastype == mujoco.mjtBias.mjBIAS_AFFINE
    G[dof, np.arange(model.nu)] = gear * model.actuator_gainprm[:, 0]
    np.add.at(K, dof, -np.where(affine, gear**2 * model.actuator_biasprm[:, 1], 0.0))
    np.add.at(D, dof, -np.where(affine, gear**2 * model.actuator_biasprm[:, 2], 0.0))
    return K, D, G


def step_matrices(M, K, D, G, dt: float):
    """``(A, B)`` of the ``implicitfast`` step ``x' = A x + B u + const`` (module docstring) for the
    mass matrices ``M`` (..., nv, nv) and :func:`linear_forces`' ``K``, ``D``, ``G``: ``A``
    (..., 2 nv, 2 nv), ``B`` (..., 2 nv, nu). numpy arrays or torch tensors (the same operations)."""
    solve: Any
    eye: Any
    cat: Any
    if isinstance(M, np.ndarray):
        solve, eye, cat = np.linalg.solve, np.eye(M.shape[-1]), np.concatenate
    else:
        import torch

        solve, cat = torch.linalg.solve, torch.cat
        eye = torch.eye(M.shape[-1], dtype=M.dtype, device=M.device)
    Mh = M + dt * (eye * D)
    # dv'/dq = -dt Mh^-1 K, dv'/dv = I - dt Mh^-1 D, dv'/du = dt Mh^-1 G; q' = q + dt v'
    z = 0 * M  # the batch's shape
    S = solve(Mh, cat([z + eye * K, z + eye * D, z[..., :1] + G], -1)) * dt
    nv = M.shape[-1]
    dvdq, dvdv, dvdu = -S[..., :nv], eye - S[..., nv : 2 * nv], S[..., 2 * nv :]
    A = cat([cat([z + eye + dt * dvdq, dt * dvdv], -1), cat([dvdq, dvdv], -1)], -2)
    B = cat([dt * dvdu, dvdu], -2)
    return A, B


@nb.njit(cache=DISK_CACHE, nogil=True)
def _affine_run(A, Bc, u0, c, x, U, start, moved, stride, adr, lo, hi, out):  # pragma: no cover - compiled
    """Iterate ``x <- A x + Bc (U[k] - u0) + c`` in place for k = 0, 1, ... while every coordinate
    ``x[moved]`` stays within ``stride`` of ``start`` and every limited coordinate ``x[adr]`` inside
    ``(lo, hi)``; with ``out`` of U's length, ``out[k]`` is the state after step k. Returns the steps
    taken and why it stopped: 0 all done, 1 the stride, 2 a joint's range (x is then the state before
    the step that would reach it)."""
    n, m = x.shape[0], U.shape[1]
    y = np.empty(n)
    for k in range(U.shape[0]):
        for i in range(moved.shape[0]):
            if abs(x[moved[i]] - start[moved[i]]) > stride:
                return k, 1
        for i in range(n):
            s = c[i]
            for j in range(m):
                s += Bc[i, j] * (U[k, j] - u0[j])
            for j in range(n):
                s += A[i, j] * x[j]
            y[i] = s
        for i in range(adr.shape[0]):
            q = y[adr[i]]
            if not (lo[i] < q < hi[i]):
                return k, 2
        for i in range(n):
            x[i] = y[i]
        if out.shape[0]:
            for i in range(n):
                out[k, i] = x[i]
    return U.shape[0], 0


class _Segment:
    """One linear map in use: ``x' = A x + Bc (u - u0) + c`` from the exact step ``x1`` (``start``),
    the state ``x`` it last wrote, ``n`` steps after its own start at ``time0``."""

    __slots__ = ("A", "Bc", "u0", "c", "start", "x", "time0", "n", "dt", "others", "qfrc", "xfrc")

    def __init__(self, A, Bc, u0, c, x, time0, dt, data, other_ctrl) -> None:
        self.A, self.Bc, self.u0, self.c = A, Bc, u0, c
        self.start, self.x = x.copy(), x
        self.time0, self.n, self.dt = time0, 1, dt
        # what the affine offset c holds besides the state: the other controls and the applied forces
        self.others = data.ctrl[other_ctrl].copy()
        self.qfrc, self.xfrc = data.qfrc_applied.copy(), data.xfrc_applied.copy()


class LinearTail:
    """Closed-form stretches of one head's physics (see the module docstring).

    ``model``, ``data``: the head's MuJoCo model and data; ``ctrl``: the eye controls' slice or
    indices in ``data.ctrl``; ``vadr``: the eye joints' addresses in ``qvel``.

    A map, once made, is used until an eye has moved :data:`LINEAR_STRIDE_DEG` from where it was made
    or a joint would reach its range, across calls as long as nothing else has touched the state
    (``qpos``, ``qvel``, the other controls, the applied forces, the time, the timestep): so the states do not depend on
    how a stretch is cut into calls, nor on whether it is recorded."""

    def __init__(self, model, data, ctrl, vadr: np.ndarray) -> None:
        self.model, self.data, self.ctrl = model, data, ctrl
        self._forces = linear_forces(model)
        self.usable = self._forces is not None
        nv = model.nv
        self._eye = np.zeros(nv, bool)
        self._eye[np.asarray(vadr)] = True
        self._moved = np.flatnonzero(self._eye)  # qpos = qvel addresses (nq == nv)
        self._cols = np.arange(model.nu)[ctrl]
        self._other_ctrl = np.ones(model.nu, bool)
        self._other_ctrl[self._cols] = False
        self._M = np.zeros((nv, nv))
        limited = np.flatnonzero(model.jnt_limited)
        self._adr = model.jnt_qposadr[limited].astype(np.int64)
        self._lo = model.jnt_range[limited, 0].copy()
        self._hi = model.jnt_range[limited, 1].copy()
        self._stride = math.radians(LINEAR_STRIDE_DEG)
        self._seg: _Segment | None = None
        self._none = np.zeros((0, 2 * nv))

    def forget(self) -> None:
        """Drop the map in use (a reset or a new state)."""
        self._seg = None

    def ready(self) -> bool:
        """Whether the state is slow enough for the linear map: every eye joint below
        :data:`LINEAR_SPEED_DEG_S`, every other joint below :data:`REST_SPEED_DEG_S`."""
        if not self.usable:
            return False
        return slow_enough(self.data.qvel, self._eye)

    def _current(self) -> _Segment | None:
        """The map in use, if the state is still the one it wrote."""
        seg, d, m = self._seg, self.data, self.model
        if seg is None:
            return None
        nv = m.nv
        if not (
            m.opt.timestep == seg.dt
            and d.time == seg.time0 + seg.n * seg.dt
            and np.array_equal(d.qpos, seg.x[:nv])
            and np.array_equal(d.qvel, seg.x[nv:])
            and np.array_equal(d.ctrl[self._other_ctrl], seg.others)
            and np.array_equal(d.qfrc_applied, seg.qfrc)
            and np.array_equal(d.xfrc_applied, seg.xfrc)
        ):
            self._seg = None
        return self._seg

    def _begin(self, u: np.ndarray) -> _Segment:
        """A new map at the current state, and its first step taken exactly (control ``u``)."""
        m, d = self.model, self.data
        forces = self._forces
        assert forces is not None, "ready() checks the model's forces"
        x0 = np.concatenate([d.qpos, d.qvel])
        time0 = d.time
        d.ctrl[self.ctrl] = u
        mujoco.mj_step(m, d)  # the first step, exact: x1 (and the mass matrix at x0)
        mujoco.mj_fullM(m, d, self._M)
        A, B = step_matrices(self._M, *forces, m.opt.timestep)
        x1 = np.concatenate([d.qpos, d.qvel])
        # x_(k+1) = x1 + A (x_k - x0) + B (u_k - u0) = A x_k + B (u_k - u0) + (x1 - A x0)
        seg = _Segment(
            A,
            B[:, self._cols].copy(),
            u.copy(),
            x1 - A @ x0,
            x1,
            time0,
            m.opt.timestep,
            d,
            self._other_ctrl,
        )
        self._write(seg)
        return seg

    def _write(self, seg: _Segment) -> None:
        d, nv = self.data, self.model.nv
        d.qpos[:], d.qvel[:] = seg.x[:nv], seg.x[nv:]
        d.time = seg.time0 + seg.n * seg.dt

    def run(self, eye_controls: np.ndarray, record: bool = False) -> tuple[int, np.ndarray | None]:
        """Advance up to ``len(eye_controls)`` physics steps at the model's timestep, the eye controls of
        step k being ``eye_controls[k]`` (the others held); returns the steps taken and, with
        ``record``, the states ``(qpos, qvel)`` after each (steps, 2 nv). Fewer steps (none) where the
        eyes are not slow or the map would carry a joint to its range: the caller steps the physics
        from there."""
        d = self.data
        T, done = len(eye_controls), 0
        states = np.empty((T, 2 * self.model.nv)) if record else None
        while done < T:
            seg = self._current()
            if seg is None:
                if not self.ready():
                    break
                seg = self._seg = self._begin(eye_controls[done])
                if states is not None:
                    states[done] = seg.x
                done += 1
                continue
            out = states[done:] if states is not None else self._none
            k, why = _affine_run(
                seg.A,
                seg.Bc,
                seg.u0,
                seg.c,
                seg.x,
                eye_controls[done:],
                seg.start,
                self._moved,
                self._stride,
                self._adr,
                self._lo,
                self._hi,
                out,
            )
            if k:
                seg.n += k
                self._write(seg)
                d.ctrl[self.ctrl] = eye_controls[done + k - 1]
                done += k
            if why == 1:  # the eyes moved a stride: a new map where they are
                self._seg = None
            elif why == 2:  # a joint would reach its range: the caller steps (the solver acts there)
                self._seg = None
                break
        return done, (states[:done] if states is not None else None)
