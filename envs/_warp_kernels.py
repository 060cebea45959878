"""Warp kernels of the batched saccade controller (imported by ``envs.batched_physics`` on first use:
it needs warp-lang; no ``from __future__ import annotations`` here, Warp reads the annotations)."""

import warp as wp

__all__ = ["servo", "write_setpoints", "advance", "beyond_range", "affine_run"]


@wp.func
def write_setpoints(
    u: wp.array3d(dtype=wp.float32),
    ncmd: wp.array(dtype=wp.int32),
    step: int,
    w: int,
    k: int,
    pos0: wp.int32,
    vel0: wp.int32,
    ff0: wp.int32,
    ctrl: wp.array2d(dtype=wp.float32),
):
    """Set-points of joint k of world w for physics step ``step``: row ``step`` of the world's table of
    ``models.servo_setpoints`` (position, velocity, feed-forward), its last row -- the endpoint held
    with no velocity and no feed-forward -- from then on."""
    i = wp.min(step, ncmd[w] - 1)
    ctrl[w, pos0 + k] = u[w, i, k]
    ctrl[w, vel0 + k] = u[w, i, 6 + k]
    ctrl[w, ff0 + k] = u[w, i, 12 + k]


@wp.kernel
def servo(
    u: wp.array3d(dtype=wp.float32),
    ncmd: wp.array(dtype=wp.int32),
    step: wp.array(dtype=wp.int32),
    pos0: wp.int32,
    vel0: wp.int32,
    ff0: wp.int32,
    ctrl: wp.array2d(dtype=wp.float32),
):
    """:func:`write_setpoints` of joint k of world w for physics step ``step[0]``."""
    w, k = wp.tid()
    write_setpoints(u, ncmd, step[0], w, k, pos0, vel0, ff0, ctrl)


@wp.kernel
def advance(step: wp.array(dtype=wp.int32)):
    """The next physics step's index (a kernel, so that a captured graph replays it)."""
    step[0] = step[0] + 1


@wp.kernel
def beyond_range(
    qpos: wp.array2d(dtype=wp.float32),
    adr: wp.array(dtype=wp.int32),
    lo: wp.array(dtype=wp.float32),
    hi: wp.array(dtype=wp.float32),
    left: wp.array(dtype=wp.int32),
):
    """``left[0] = 1`` where limited joint j of world w is at or beyond its range: the state in which
    MuJoCo's joint-limit constraint acts (``mjCNSTR_LIMIT_JOINT``, active for distance < margin = 0)."""
    w, j = wp.tid()
    q = qpos[w, adr[j]]
    if q <= lo[j] or q >= hi[j]:
        left[0] = 1


@wp.kernel
def affine_run(
    A: wp.array3d(dtype=wp.float64),
    W: wp.array3d(dtype=wp.float64),
    x: wp.array2d(dtype=wp.float64),
    y: wp.array2d(dtype=wp.float64),
    adr: wp.array(dtype=wp.int32),
    lo: wp.array(dtype=wp.float64),
    hi: wp.array(dtype=wp.float64),
    left: wp.array(dtype=wp.int32),
):
    """World w's state ``x[w] <- A[w] x[w] + W[w, k]`` for k = 0, 1, ... (``models.linear_tail``'s map;
    ``y`` scratch of x's shape); ``left[0] = 1`` where a limited coordinate ``x[w, adr[j]]`` reaches
    ``[lo[j], hi[j]]``'s bounds on the way."""
    w = wp.tid()
    n = x.shape[1]
    for k in range(W.shape[1]):
        for i in range(n):
            s = W[w, k, i]
            for j in range(n):
                s += A[w, i, j] * x[w, j]
            y[w, i] = s
        for i in range(n):
            x[w, i] = y[w, i]
        for j in range(adr.shape[0]):
            q = x[w, adr[j]]
            if q <= lo[j] or q >= hi[j]:
                left[0] = 1
