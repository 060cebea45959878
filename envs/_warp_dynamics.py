"""A whole run of MuJoCo's ``implicitfast`` step in one Warp kernel, one thread per world, for a
tree of hinge joints with no contacts (the head: neck, head and two eyeballs, 8 hinges).

MuJoCo Warp's ``step`` is ~60 kernel launches per physics step; on Warp's CPU backend and on a GPU
alike the launches, not the arithmetic, are its cost. :func:`tree_model` packs the compiled model's
bodies, joints, degrees of freedom and actuators once; :data:`run_tree` then steps each world
``steps`` milliseconds in float64, reading the servo's set-points from the command table as
``envs._warp_kernels.servo`` does. Each step is MuJoCo's (``engine_forward.c``, ``engine_core_smooth.c``):

- kinematics (``mj_kinematics``): each body's frame from its parent's, each hinge rotating about its
  axis through its anchor by ``qpos - qpos0`` after the body's earlier joints;
- ``cdof`` (motion subspaces about the world origin), velocities and the velocity-product
  accelerations (``mj_comVel``); the bias force ``C(q, v) v`` by recursive Newton-Euler (``mj_rne``),
  with gravity acting as ``(1 - gravcomp) m g`` at each centre of mass (MuJoCo's ``qfrc_bias``
  gravity and ``qfrc_gravcomp``, summed);
- the joint-space inertia by the composite-rigid-body sums ``M_kl = sum_b cdof_l . I_b cdof_k``, plus
  armature (``mj_crb``);
- springs, dampers (``mj_passive``) and affine joint actuators with their control and force ranges
  (``mj_fwdActuation``);
- the joints' limits: MuJoCo's soft constraints (``mj_instantiateLimit``, ``mj_makeImpedance``: impedance
  from ``solimp``, reference acceleration from ``solref``, ``R`` from ``dof_invweight0``) and the exact
  minimum of its constraint solver's cost, found by active sets (each limit acts on one dof);
- ``implicitfast`` (``mj_implicit``): ``(M - dt qDeriv) a = qfrc_smooth + qfrc_constraint`` with
  ``qDeriv`` the dampers' and the actuators' velocity feedback (no velocity-product derivative), by
  Cholesky; ``v += dt a``, ``q += dt v``.

``left[0] = 1`` where a world's active set did not settle or its state is not finite at the end (the
caller then steps the run again with MuJoCo Warp's solver). Checked against MuJoCo's C ``mj_step`` in ``tests/test_batched_physics.py``
(gravity, the velocity products and the limits exercised).
"""

import numpy as np
import warp as wp

from ._warp_kernels import write_setpoints

__all__ = ["Tree", "tree_model", "run_tree"]


@wp.struct
class Tree:
    """The model's moving bodies (parents first), hinges, degrees of freedom and actuators."""

    parent: wp.array(dtype=wp.int32)  # index among the moving bodies, -1: a fixed parent (its frame below)
    parent_pos: wp.array(dtype=wp.vec3d)  # a fixed parent's frame (world coordinates)
    parent_mat: wp.array(dtype=wp.mat33d)
    pos: wp.array(dtype=wp.vec3d)  # body_pos, body_quat as a matrix
    rot: wp.array(dtype=wp.mat33d)
    ipos: wp.array(dtype=wp.vec3d)  # centre of mass and principal axes in the body frame
    irot: wp.array(dtype=wp.mat33d)
    mass: wp.array(dtype=wp.float64)
    inertia: wp.array(dtype=wp.vec3d)
    weight: wp.array(dtype=wp.vec3d)  # (1 - gravcomp) m g: the force gravity leaves on the body
    jnt0: wp.array(dtype=wp.int32)  # the body's hinges: jnt0 .. jnt0 + njnt - 1
    njnt: wp.array(dtype=wp.int32)
    lastdof: wp.array(dtype=wp.int32)  # the last dof on the body's path from the root
    jnt_pos: wp.array(dtype=wp.vec3d)
    jnt_axis: wp.array(dtype=wp.vec3d)
    jnt_qadr: wp.array(dtype=wp.int32)
    jnt_dof: wp.array(dtype=wp.int32)
    jnt_qpos0: wp.array(dtype=wp.float64)
    jnt_stiffness: wp.array(dtype=wp.float64)
    jnt_spring: wp.array(dtype=wp.float64)
    dof_parent: wp.array(dtype=wp.int32)
    dof_body: wp.array(dtype=wp.int32)  # index among the moving bodies
    dof_damping: wp.array(dtype=wp.float64)
    dof_armature: wp.array(dtype=wp.float64)
    dof_implicit: wp.array(dtype=wp.float64)  # -dt qDeriv's diagonal: the implicit step's addition to M
    act_dof: wp.array(dtype=wp.int32)
    act_qadr: wp.array(dtype=wp.int32)
    act_gear: wp.array(dtype=wp.float64)
    act_gain: wp.array(dtype=wp.float64)
    act_bias: wp.array(dtype=wp.vec3d)  # biasprm[:3] (zero where biastype is none)
    act_ctrl: wp.array(dtype=wp.vec3d)  # (clamped 0/1, low, high)
    act_force: wp.array(dtype=wp.vec3d)  # (clamped 0/1, low, high)
    lim_qadr: wp.array(dtype=wp.int32)
    lim_dof: wp.array(dtype=wp.int32)
    lim_lo: wp.array(dtype=wp.float64)
    lim_hi: wp.array(dtype=wp.float64)
    lim_invweight: wp.array(dtype=wp.float64)  # dof_invweight0: MuJoCo's diagonal approximation
    lim_solimp: wp.array(dtype=wp.types.vector(5, wp.float64))
    lim_kb: wp.array(dtype=wp.vec2d)  # the reference acceleration's stiffness K and damping B
    limits: wp.int32  # 0 where the model's limits are disabled
    dt: wp.float64


#: model fields (MuJoCo 4) whose nonzero values change forces this kernel does not compute
_UNMODELLED = (
    "dof_dampingpoly",
    "jnt_stiffnesspoly",
    "jnt_springyield",
    "actuator_damping",
    "actuator_dampingpoly",
    "actuator_armature",
    "actuator_delay",
)

#: disable flags that change the smooth dynamics this kernel computes (it does not model them)
_DYNAMICS_FLAGS = ("mjDSBL_GRAVITY", "mjDSBL_SPRING", "mjDSBL_DAMPER", "mjDSBL_CLAMPCTRL", "mjDSBL_ACTUATION")


def _mat(quat: np.ndarray) -> np.ndarray:
    import mujoco

    out = np.zeros(9)
    mujoco.mju_quat2Mat(out, np.asarray(quat, np.float64))
    return out.reshape(3, 3)


def tree_model(mjm, device) -> "Tree | None":
    """The :class:`Tree` of a compiled ``mujoco.MjModel`` on ``device``, or None where the kernel does
    not model it: a joint other than a hinge, an actuator other than a fixed-gain, affine-bias joint
    actuator without dynamics, delay, damping or armature of its own (or with a force range and
    velocity feedback: MuJoCo then drops the feedback from ``qDeriv`` while it saturates), disabled
    actuator groups, polynomial or yielding springs and dampers, tendons, equality constraints,
    contacts, fluid forces, plugins, joint actuator-force limits or gravity compensation through the
    actuators, friction loss, a moving body under a mocap body, an integrator other than
    ``implicitfast``, a disabled gravity/spring/damper/actuation/control clamp, or an enable flag."""
    import mujoco

    T, D = mujoco.mjtJoint, mujoco.mjtDisableBit
    flags = 0
    for name in _DYNAMICS_FLAGS:
        flags |= int(getattr(D, name))
    if (
        mjm.opt.integrator != mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        or mjm.nq != mjm.nv
        or mjm.nv == 0
        or mjm.na
        or mjm.ntendon
        or mjm.neq
        or mjm.nflex
        or not (mjm.opt.disableflags & D.mjDSBL_CONTACT)
        or mjm.opt.disableflags & flags
        or mjm.opt.enableflags
        or mjm.opt.density
        or mjm.opt.viscosity
        or np.any(mjm.jnt_type != T.mjJNT_HINGE)
        or np.any(mjm.jnt_actfrclimited)
        or np.any(mjm.dof_frictionloss)
        or np.any(mjm.jnt_margin[mjm.jnt_limited.astype(bool)])
        or np.any(mjm.jnt_solref[mjm.jnt_limited.astype(bool)] <= 0)  # the direct format: not modelled
        or np.any(mjm.actuator_trntype != mujoco.mjtTrn.mjTRN_JOINT)
        or np.any(mjm.actuator_dyntype != mujoco.mjtDyn.mjDYN_NONE)
        or np.any(mjm.actuator_gaintype != mujoco.mjtGain.mjGAIN_FIXED)
        or not np.all(np.isin(mjm.actuator_biastype, (mujoco.mjtBias.mjBIAS_NONE, mujoco.mjtBias.mjBIAS_AFFINE)))
        or np.any(mjm.actuator_forcelimited.astype(bool) & (mjm.actuator_biasprm[:, 2] != 0))
        or mjm.opt.disableactuator
        or mjm.nplugin
        or np.any(mjm.jnt_actgravcomp)
        or any(np.any(getattr(mjm, name, 0)) for name in _UNMODELLED)
    ):
        return None
    # the moving bodies: a dof on their path from the world, parents before children (MuJoCo's order)
    moves = np.zeros(mjm.nbody, bool)
    for b in range(1, mjm.nbody):
        moves[b] = mjm.body_dofnum[b] > 0 or moves[mjm.body_parentid[b]]
    bodies = np.flatnonzero(moves)
    for b in bodies:  # a mocap ancestor would move each world's tree (the parents' frames are baked)
        while b > 0:
            if mjm.body_mocapid[b] >= 0:
                return None
            b = mjm.body_parentid[b]
    index = np.full(mjm.nbody, -1)
    index[bodies] = np.arange(len(bodies))
    data = mujoco.MjData(mjm)
    mujoco.mj_kinematics(mjm, data)  # the fixed parents' frames (they do not depend on qpos)
    parents = mjm.body_parentid[bodies]
    jnt0 = mjm.body_jntadr[bodies]
    njnt = mjm.body_jntnum[bodies]
    if np.any(np.diff(np.concatenate([[0], [j for j, k in zip(jnt0, njnt) if k]])) < 0):
        raise ValueError("the model's joints are not in its bodies' order")
    # the last dof on each body's path: its own last, else its parent's
    lastdof = np.full(len(bodies), -1)
    for i, body in enumerate(bodies):
        own = mjm.body_dofadr[body] + mjm.body_dofnum[body] - 1 if mjm.body_dofnum[body] else -1
        lastdof[i] = own if own >= 0 or index[parents[i]] < 0 else lastdof[index[parents[i]]]
    dt = float(mjm.opt.timestep)
    gear = mjm.actuator_gear[:, 0].astype(np.float64)
    act_dof = mjm.jnt_dofadr[mjm.actuator_trnid[:, 0]]
    affine = mjm.actuator_biastype == mujoco.mjtBias.mjBIAS_AFFINE
    bias = np.where(affine[:, None], mjm.actuator_biasprm[:, :3], 0.0)
    implicit = dt * mjm.dof_damping.copy()
    np.add.at(implicit, act_dof, -dt * gear**2 * bias[:, 2])
    limited = np.flatnonzero(mjm.jnt_limited)
    # the joint limits' soft constraints (engine_core_constraint.c: getsolparam, mj_makeImpedance)
    solref = mjm.jnt_solref[limited].astype(np.float64).copy()
    if not (mjm.opt.disableflags & D.mjDSBL_REFSAFE):
        solref[:, 0] = np.maximum(solref[:, 0], 2 * dt)
    solimp = mjm.jnt_solimp[limited].astype(np.float64).copy()
    solimp[:, [0, 1, 3]] = np.clip(solimp[:, [0, 1, 3]], mujoco.mjMINIMP, mujoco.mjMAXIMP)
    solimp[:, 2] = np.maximum(solimp[:, 2], 0.0)
    solimp[:, 4] = np.maximum(solimp[:, 4], 1.0)
    dmax = solimp[:, 1]
    kb = np.column_stack(
        [
            1.0 / np.maximum(mujoco.mjMINVAL, dmax**2 * solref[:, 0] ** 2 * solref[:, 1] ** 2),
            2.0 / np.maximum(mujoco.mjMINVAL, dmax * solref[:, 0]),
        ]
    )

    def arr(a, dtype):
        return wp.array(np.ascontiguousarray(a), dtype=dtype, device=device)

    t = Tree()
    t.parent = arr(index[parents], wp.int32)
    t.parent_pos = arr(data.xpos[parents], wp.vec3d)
    t.parent_mat = arr(data.xmat[parents].reshape(-1, 3, 3), wp.mat33d)
    t.pos = arr(mjm.body_pos[bodies], wp.vec3d)
    t.rot = arr(np.stack([_mat(q) for q in mjm.body_quat[bodies]]), wp.mat33d)
    t.ipos = arr(mjm.body_ipos[bodies], wp.vec3d)
    t.irot = arr(np.stack([_mat(q) for q in mjm.body_iquat[bodies]]), wp.mat33d)
    t.mass = arr(mjm.body_mass[bodies], wp.float64)
    t.inertia = arr(mjm.body_inertia[bodies], wp.vec3d)
    t.weight = arr(
        (1.0 - mjm.body_gravcomp[bodies])[:, None] * mjm.body_mass[bodies][:, None] * mjm.opt.gravity, wp.vec3d
    )
    t.jnt0, t.njnt, t.lastdof = arr(jnt0, wp.int32), arr(njnt, wp.int32), arr(lastdof, wp.int32)
    t.jnt_pos, t.jnt_axis = arr(mjm.jnt_pos, wp.vec3d), arr(mjm.jnt_axis, wp.vec3d)
    t.jnt_qadr, t.jnt_dof = arr(mjm.jnt_qposadr, wp.int32), arr(mjm.jnt_dofadr, wp.int32)
    t.jnt_qpos0 = arr(mjm.qpos0[mjm.jnt_qposadr], wp.float64)
    t.jnt_stiffness = arr(mjm.jnt_stiffness, wp.float64)
    t.jnt_spring = arr(mjm.qpos_spring[mjm.jnt_qposadr], wp.float64)
    t.dof_parent, t.dof_body = arr(mjm.dof_parentid, wp.int32), arr(index[mjm.dof_bodyid], wp.int32)
    t.dof_damping, t.dof_implicit = arr(mjm.dof_damping, wp.float64), arr(implicit, wp.float64)
    t.dof_armature = arr(mjm.dof_armature, wp.float64)
    t.act_dof, t.act_qadr = arr(act_dof, wp.int32), arr(mjm.jnt_qposadr[mjm.actuator_trnid[:, 0]], wp.int32)
    t.act_gear, t.act_gain = arr(gear, wp.float64), arr(mjm.actuator_gainprm[:, 0], wp.float64)
    t.act_bias = arr(bias, wp.vec3d)
    t.act_ctrl = arr(np.column_stack([mjm.actuator_ctrllimited, mjm.actuator_ctrlrange]), wp.vec3d)
    t.act_force = arr(np.column_stack([mjm.actuator_forcelimited, mjm.actuator_forcerange]), wp.vec3d)
    t.lim_qadr, t.lim_dof = arr(mjm.jnt_qposadr[limited], wp.int32), arr(mjm.jnt_dofadr[limited], wp.int32)
    t.lim_lo, t.lim_hi = arr(mjm.jnt_range[limited, 0], wp.float64), arr(mjm.jnt_range[limited, 1], wp.float64)
    t.lim_invweight = arr(mjm.dof_invweight0[mjm.jnt_dofadr[limited]], wp.float64)
    t.lim_solimp = arr(solimp.reshape(-1, 5), wp.types.vector(5, wp.float64))
    t.lim_kb = arr(kb.reshape(-1, 2), wp.vec2d)
    t.limits = wp.int32(0 if mjm.opt.disableflags & (D.mjDSBL_LIMIT | D.mjDSBL_CONSTRAINT) else 1)
    t.dt = wp.float64(dt)
    return t


@wp.struct
class Scratch:
    """Each world's working arrays (first axis: the world)."""

    q: wp.array2d(dtype=wp.float64)
    v: wp.array2d(dtype=wp.float64)
    f: wp.array2d(dtype=wp.float64)
    M: wp.array3d(dtype=wp.float64)
    xpos: wp.array2d(dtype=wp.vec3d)
    xmat: wp.array2d(dtype=wp.mat33d)
    com: wp.array2d(dtype=wp.vec3d)
    inertia: wp.array2d(dtype=wp.mat33d)  # rotational inertia about the centre of mass, world axes
    cdof_w: wp.array2d(dtype=wp.vec3d)  # each dof's motion: angular, linear (of the point at the origin)
    cdof_v: wp.array2d(dtype=wp.vec3d)
    vel_w: wp.array2d(dtype=wp.vec3d)  # each body's spatial velocity, bias acceleration and force
    vel_v: wp.array2d(dtype=wp.vec3d)
    frc_n: wp.array2d(dtype=wp.vec3d)
    frc_f: wp.array2d(dtype=wp.vec3d)
    A: wp.array3d(dtype=wp.float64)  # the constraint solver's matrix and its solution
    a: wp.array2d(dtype=wp.float64)
    lim_on: wp.array2d(dtype=wp.int32)  # each limit: 0 off, 1 within reach (its distance < 0), 2 pushing
    lim_sign: wp.array2d(dtype=wp.float64)  # the constraint's Jacobian on its dof (+1 lower, -1 upper)
    lim_d: wp.array2d(dtype=wp.float64)  # D = 1 / R
    lim_aref: wp.array2d(dtype=wp.float64)


def scratch(num_worlds: int, nv: int, nbody: int, nlimit: int, device) -> "Scratch":
    """:class:`Scratch` for ``num_worlds`` worlds of ``nv`` dofs, ``nbody`` moving bodies and ``nlimit``
    limited joints."""
    s = Scratch()
    with wp.ScopedDevice(device):
        s.q, s.v, s.f, s.a = (wp.zeros((num_worlds, nv), dtype=wp.float64) for _ in range(4))
        s.M, s.A = (wp.zeros((num_worlds, nv, nv), dtype=wp.float64) for _ in range(2))
        s.lim_on = wp.zeros((num_worlds, max(nlimit, 1)), dtype=wp.int32)
        s.lim_sign, s.lim_d, s.lim_aref = (wp.zeros((num_worlds, max(nlimit, 1)), dtype=wp.float64) for _ in range(3))
        s.xpos, s.com, s.vel_w, s.vel_v, s.frc_n, s.frc_f = (
            wp.zeros((num_worlds, nbody), dtype=wp.vec3d) for _ in range(6)
        )
        s.xmat, s.inertia = (wp.zeros((num_worlds, nbody), dtype=wp.mat33d) for _ in range(2))
        s.cdof_w, s.cdof_v = (wp.zeros((num_worlds, nv), dtype=wp.vec3d) for _ in range(2))
    return s


@wp.func
def _hinge(axis: wp.vec3d, angle: wp.float64) -> wp.mat33d:
    """The rotation by ``angle`` about the unit ``axis`` (Rodrigues; MuJoCo's ``mju_axisAngle2Quat``)."""
    K = wp.skew(axis)
    return wp.identity(3, dtype=wp.float64) + wp.sin(angle) * K + (wp.float64(1.0) - wp.cos(angle)) * (K @ K)


@wp.func
def _inertia_times(m: wp.float64, c: wp.vec3d, Ic: wp.mat33d, w: wp.vec3d, v: wp.vec3d):
    """A body's spatial inertia about the origin times the motion ``(w, v)`` (``v``: the velocity of the
    body-fixed point at the origin): the momentum ``(n, f)``, ``f = m (v + w x c)``, ``n = Ic w + c x f``."""
    f = m * (v + wp.cross(w, c))
    return Ic @ w + wp.cross(c, f), f


@wp.func
def _factor(A: wp.array3d(dtype=wp.float64), w: wp.int32, n: wp.int32):
    """World w's symmetric positive definite ``A`` (its lower triangle) -> its Cholesky factor, in place."""
    for k in range(n):
        d = A[w, k, k]
        for p in range(k):
            d = d - A[w, k, p] * A[w, k, p]
        d = wp.sqrt(d)
        A[w, k, k] = d
        for i in range(k + 1, n):
            e = A[w, i, k]
            for p in range(k):
                e = e - A[w, i, p] * A[w, k, p]
            A[w, i, k] = e / d


@wp.func
def _solve(L: wp.array3d(dtype=wp.float64), w: wp.int32, b: wp.array2d(dtype=wp.float64), n: wp.int32):
    """``b[w] <- (L L^T)^-1 b[w]`` with :func:`_factor`'s ``L``."""
    for i in range(n):
        e = b[w, i]
        for p in range(i):
            e = e - L[w, i, p] * b[w, p]
        b[w, i] = e / L[w, i, i]
    for ii in range(n):
        i = n - 1 - ii
        e = b[w, i]
        for p in range(i + 1, n):
            e = e - L[w, p, i] * b[w, p]
        b[w, i] = e / L[w, i, i]


@wp.func
def _impedance(solimp: wp.types.vector(5, wp.float64), pos: wp.float64) -> wp.float64:
    """MuJoCo's constraint impedance at distance ``pos`` (margin 0; ``getimpedance``)."""
    d0 = solimp[0]
    d1 = solimp[1]
    width = solimp[2]
    mid = solimp[3]
    power = solimp[4]
    one = wp.float64(1.0)
    if d0 == d1 or width <= wp.float64(1e-15):
        return wp.float64(0.5) * (d0 + d1)
    x = wp.abs(pos / width)
    if x >= one:
        return d1
    if x <= wp.float64(0.0):
        return d0
    y = x
    if power != one:
        if x <= mid:
            y = wp.pow(x, power) / wp.pow(mid, power - one)
        else:
            y = one - wp.pow(one - x, power) / wp.pow(one - mid, power - one)
    return d0 + y * (d1 - d0)


@wp.func
def _limit_forces(tree: Tree, s: Scratch, w: wp.int32, nv: wp.int32) -> wp.int32:
    """The joint limits' constraint forces added to ``s.f[w]`` (the smooth forces): MuJoCo's soft
    limits (``mj_instantiateLimit``, ``mj_makeImpedance``, ``mj_referenceConstraint``) and the exact
    minimum of its constraint solver's convex cost ``0.5 (a - a0)' M (a - a0) + sum 0.5 D min(0, J a -
    aref)^2`` by active sets (each limit's Jacobian is one dof). Returns 1 where it did not settle."""
    nl = tree.lim_qadr.shape[0]
    zero = wp.float64(0.0)
    near = wp.int32(0)
    for j in range(nl):
        x = s.q[w, tree.lim_qadr[j]]
        pos = x - tree.lim_lo[j]
        sign = wp.float64(1.0)
        if tree.lim_hi[j] - x < pos:
            pos = tree.lim_hi[j] - x
            sign = wp.float64(-1.0)
        s.lim_on[w, j] = 0
        if pos < zero:
            imp = _impedance(tree.lim_solimp[j], pos)
            r = wp.max(wp.float64(1e-15), (wp.float64(1.0) - imp) * tree.lim_invweight[j] / imp)
            kb = tree.lim_kb[j]
            s.lim_on[w, j] = 1
            s.lim_sign[w, j] = sign
            s.lim_d[w, j] = wp.float64(1.0) / r
            s.lim_aref[w, j] = -kb[1] * sign * s.v[w, tree.lim_dof[j]] - kb[0] * imp * pos
            near = near + 1
    if near == 0:
        return 0
    # solve with the pushing limits (none at first: a0 = M^-1 f), then update which push, until they repeat
    settled = wp.int32(0)
    for _it in range(17):
        for i in range(nv):
            s.a[w, i] = s.f[w, i]
            for k in range(i + 1):
                s.A[w, i, k] = s.M[w, i, k]
        for j in range(nl):
            if s.lim_on[w, j] == 2:
                dof = tree.lim_dof[j]
                s.A[w, dof, dof] = s.A[w, dof, dof] + s.lim_d[w, j]
                s.a[w, dof] = s.a[w, dof] + s.lim_d[w, j] * s.lim_sign[w, j] * s.lim_aref[w, j]
        _factor(s.A, w, nv)
        _solve(s.A, w, s.a, nv)
        changed = wp.int32(0)
        for j in range(nl):
            if s.lim_on[w, j] > 0:
                on = 1
                if s.lim_sign[w, j] * s.a[w, tree.lim_dof[j]] - s.lim_aref[w, j] < zero:
                    on = 2
                if on != s.lim_on[w, j]:
                    changed = 1
                s.lim_on[w, j] = on
        if changed == 0:
            settled = 1
            break
    for j in range(nl):
        if s.lim_on[w, j] == 2:
            dof = tree.lim_dof[j]
            force = -s.lim_d[w, j] * (s.lim_sign[w, j] * s.a[w, dof] - s.lim_aref[w, j])
            s.f[w, dof] = s.f[w, dof] + s.lim_sign[w, j] * force
    return 1 - settled


@wp.kernel
def run_tree(
    tree: Tree,
    s: Scratch,
    qpos: wp.array2d(dtype=wp.float32),
    qvel: wp.array2d(dtype=wp.float32),
    ctrl: wp.array2d(dtype=wp.float32),
    time: wp.array(dtype=wp.float32),
    cmd: wp.array3d(dtype=wp.float32),
    ncmd: wp.array(dtype=wp.int32),
    first: wp.int32,
    steps: wp.int32,
    pos0: wp.int32,
    vel0: wp.int32,
    ff0: wp.int32,
    left: wp.array(dtype=wp.int32),
):
    """World w stepped ``steps`` ms from set-point row ``first`` (module docstring)."""
    w = wp.tid()
    nv = s.q.shape[1]
    nb = tree.parent.shape[0]
    zero = wp.vec3d(wp.float64(0.0), wp.float64(0.0), wp.float64(0.0))
    dt = tree.dt
    for i in range(nv):
        s.q[w, i] = wp.float64(qpos[w, i])
        s.v[w, i] = wp.float64(qvel[w, i])
    for step in range(steps):
        for k in range(6):  # the servo's set-points, as the servo kernel writes them
            write_setpoints(cmd, ncmd, first + step, w, k, pos0, vel0, ff0, ctrl)
        # kinematics, motion subspaces, velocities, bias forces
        for b in range(nb):
            p = tree.parent[b]
            pos = tree.parent_pos[b]
            mat = tree.parent_mat[b]
            cw = zero
            cv = zero
            aw = zero
            av = zero
            if p >= 0:
                pos = s.xpos[w, p]
                mat = s.xmat[w, p]
                cw = s.vel_w[w, p]
                cv = s.vel_v[w, p]
                aw = s.frc_n[w, p]  # the parent's bias acceleration, kept here until its force is made
                av = s.frc_f[w, p]
            pos = pos + mat @ tree.pos[b]
            mat = mat @ tree.rot[b]
            for j in range(tree.jnt0[b], tree.jnt0[b] + tree.njnt[b]):
                dof = tree.jnt_dof[j]
                anchor = pos + mat @ tree.jnt_pos[j]
                a = mat @ tree.jnt_axis[j]
                lin = wp.cross(anchor, a)
                s.cdof_w[w, dof] = a
                s.cdof_v[w, dof] = lin
                qd = s.v[w, dof]
                aw = aw + wp.cross(cw, a) * qd  # cdof_dot qvel, cdof_dot = cvel x cdof (mj_comVel)
                av = av + (wp.cross(cw, lin) + wp.cross(cv, a)) * qd
                cw = cw + a * qd
                cv = cv + lin * qd
                mat = mat @ _hinge(tree.jnt_axis[j], s.q[w, tree.jnt_qadr[j]] - tree.jnt_qpos0[j])
                pos = anchor - mat @ tree.jnt_pos[j]
            s.xpos[w, b] = pos
            s.xmat[w, b] = mat
            c = pos + mat @ tree.ipos[b]
            R = mat @ tree.irot[b]
            Ic = R @ wp.diag(tree.inertia[b]) @ wp.transpose(R)
            s.com[w, b] = c
            s.inertia[w, b] = Ic
            s.vel_w[w, b] = cw
            s.vel_v[w, b] = cv
            s.frc_n[w, b] = aw
            s.frc_f[w, b] = av
        for bb in range(nb):  # children after parents: the accelerations above are read before this
            b = nb - 1 - bb
            m = tree.mass[b]
            c = s.com[w, b]
            Ic = s.inertia[w, b]
            cw = s.vel_w[w, b]
            cv = s.vel_v[w, b]
            n1, f1 = _inertia_times(m, c, Ic, s.frc_n[w, b], s.frc_f[w, b])
            n2, f2 = _inertia_times(m, c, Ic, cw, cv)
            g = tree.weight[b]
            s.frc_n[w, b] = n1 + wp.cross(cw, n2) + wp.cross(cv, f2) - wp.cross(c, g)
            s.frc_f[w, b] = f1 + wp.cross(cw, f2) - g
        for bb in range(nb):  # each body's force plus its subtree's (mj_rne's backward pass)
            b = nb - 1 - bb
            p = tree.parent[b]
            if p >= 0:
                s.frc_n[w, p] = s.frc_n[w, p] + s.frc_n[w, b]
                s.frc_f[w, p] = s.frc_f[w, p] + s.frc_f[w, b]
        # the mass matrix (lower triangle) plus armature and the implicit damping
        for i in range(nv):
            for k in range(nv):
                s.M[w, i, k] = wp.float64(0.0)
        for b in range(nb):
            m = tree.mass[b]
            c = s.com[w, b]
            Ic = s.inertia[w, b]
            k = tree.lastdof[b]
            while k >= 0:
                fn, ff = _inertia_times(m, c, Ic, s.cdof_w[w, k], s.cdof_v[w, k])
                l = k
                while l >= 0:
                    s.M[w, k, l] = s.M[w, k, l] + wp.dot(s.cdof_w[w, l], fn) + wp.dot(s.cdof_v[w, l], ff)
                    l = tree.dof_parent[l]
                k = tree.dof_parent[k]
        for i in range(nv):
            b = tree.dof_body[i]
            s.f[w, i] = -(wp.dot(s.cdof_w[w, i], s.frc_n[w, b]) + wp.dot(s.cdof_v[w, i], s.frc_f[w, b]))
            s.f[w, i] = s.f[w, i] - tree.dof_damping[i] * s.v[w, i]
            s.M[w, i, i] = s.M[w, i, i] + tree.dof_armature[i]
        for j in range(tree.jnt_dof.shape[0]):
            dof = tree.jnt_dof[j]
            s.f[w, dof] = s.f[w, dof] - tree.jnt_stiffness[j] * (s.q[w, tree.jnt_qadr[j]] - tree.jnt_spring[j])
        for a in range(tree.act_dof.shape[0]):
            dof = tree.act_dof[a]
            gear = tree.act_gear[a]
            u = wp.float64(ctrl[w, a])
            cr = tree.act_ctrl[a]
            if cr[0] > wp.float64(0.0):
                u = wp.clamp(u, cr[1], cr[2])
            bp = tree.act_bias[a]
            force = tree.act_gain[a] * u + bp[0] + bp[1] * gear * s.q[w, tree.act_qadr[a]] + bp[2] * gear * s.v[w, dof]
            fr = tree.act_force[a]
            if fr[0] > wp.float64(0.0):
                force = wp.clamp(force, fr[1], fr[2])
            s.f[w, dof] = s.f[w, dof] + gear * force
        if tree.limits != 0:
            if _limit_forces(tree, s, w, nv) != 0:
                left[0] = 1
        # (M - dt qDeriv) a = f + the limits' forces by Cholesky, in place (mj_implicit)
        for i in range(nv):
            s.M[w, i, i] = s.M[w, i, i] + tree.dof_implicit[i]
        _factor(s.M, w, nv)
        _solve(s.M, w, s.f, nv)
        # implicit in velocity, then position (mj_advance; hinges: q += dt v)
        for i in range(nv):
            s.v[w, i] = s.v[w, i] + dt * s.f[w, i]
            s.q[w, i] = s.q[w, i] + dt * s.v[w, i]
    for i in range(nv):
        if not (wp.isfinite(s.q[w, i]) and wp.isfinite(s.v[w, i])):
            left[0] = 1  # diverged (or NaN in): MuJoCo Warp's own step decides what happens
        qpos[w, i] = wp.float32(s.q[w, i])
        qvel[w, i] = wp.float32(s.v[w, i])
    time[w] = wp.float32(wp.float64(time[w]) + wp.float64(steps) * dt)
