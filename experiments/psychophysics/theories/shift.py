"""The log-radius-shift read-out that ``paper`` and ``mechanistic`` share (the paper's §6.5): the
target-centred map shifted by a gain towards the target, its activity centroid read out through an
eye-position estimate, and -- for ``mechanistic`` -- mixed with the route anchored on what the eyes
see after the saccade."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["shift_read"]


def shift_read(
    runner, flash: dict, gain, weight, seen, copy_pose, read_pose, true_pose, threshold: float, anchored: bool
):
    """Per eye, the perceived position (head-centred deg) of an observed flash and its closed form,
    and the maps (for recordings). ``anchored``: the two-route read-out (``weight`` of the route
    anchored on ``seen``, the rest the unremapped extraretinal route); else the shifted map through
    ``read_pose`` alone."""
    grid, fl_h = runner.grid, flash["head"]
    perceived, closed, maps = [], [], []
    for e, (view, centred, z_t) in enumerate(flash["eyes"]):
        (ca, co), (ra, ro), (ta, to) = ((a[e], o[e]) for a, o in (copy_pose, read_pose, true_pose))
        z_rel, shifted = runner._centroid(view, grid, centred, gain / grid.delta, threshold)
        xf = ta.T @ (fl_h - to)
        z_f = complex(xf[2], xf[0]) / xf[1]
        z_cf = z_t + (z_f - z_t) * math.exp(-gain)
        if not anchored:
            perceived.append(runner._ray_to_screen_deg(ro, ra, z_t + z_rel))
            closed.append(runner._ray_to_screen_deg(ro, ra, z_cf))
        else:
            z_rel0 = runner._centroid(view, grid, centred, 0.0, threshold)[0] if gain else z_rel
            extra = runner._ray_to_screen_deg(ro, ra, z_t + z_rel0)  # unremapped, via the signal
            extra_cf = runner._ray_to_screen_deg(ro, ra, z_f)
            if weight > 0:  # anchored on the seen target: the flash's remapped offset from it
                base = runner._ray_to_screen_deg(co, ca, z_t)
                anch = seen[e] + runner._ray_to_screen_deg(co, ca, z_t + z_rel) - base
                anch_cf = seen[e] + runner._ray_to_screen_deg(co, ca, z_cf) - base
            else:
                anch = anch_cf = np.zeros(2)
            perceived.append(weight * anch + (1 - weight) * extra)
            closed.append(weight * anch_cf + (1 - weight) * extra_cf)
        maps.append((view, centred, shifted, z_t, z_rel))
    return perceived, closed, maps
