"""Warp kernels of the batched saccade controller (imported by ``envs.batched_physics`` on first use:
it needs warp-lang; no ``from __future__ import annotations`` here, Warp reads the annotations)."""

import warp as wp

__all__ = ["servo", "advance"]


@wp.kernel
def servo(cmd: wp.array3d(dtype=wp.float32), ncmd: wp.array(dtype=wp.int32), step: wp.array(dtype=wp.int32),
          inertia: wp.float32, dt: wp.float32, pos0: wp.int32, vel0: wp.int32, ff0: wp.int32,
          ctrl: wp.array2d(dtype=wp.float32)):
    """Set-points of joint k of world w for physics step ``step[0]``: the commanded angle, the commanded
    displacement over the step / dt, and I (v_j - v_(j-1)) / dt (as ``models.Head._saccade_table``);
    from the table's last row on, the endpoint held with no feed-forward (as ``models.Head._hold``)."""
    w, k = wp.tid()
    j = step[0]
    last = ncmd[w] - 1
    i = wp.min(j, last)
    q = cmd[w, i, k]
    v = (cmd[w, wp.min(j + 1, last), k] - q) / dt
    v_prev = float(0.0)
    if j > 0 and j <= last:
        v_prev = (q - cmd[w, j - 1, k]) / dt
    ff = float(0.0)
    if j < last:  # holding the endpoint from the last row on, as the CPU head's hold: no feed-forward
        ff = inertia * (v - v_prev) / dt
    ctrl[w, pos0 + k] = q
    ctrl[w, vel0 + k] = v
    ctrl[w, ff0 + k] = ff


@wp.kernel
def advance(step: wp.array(dtype=wp.int32)):
    """The next physics step's index (a kernel, so that a captured graph replays it)."""
    step[0] = step[0] + 1
