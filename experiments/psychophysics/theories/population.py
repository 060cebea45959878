"""The ``population`` theory's read-out (the model: ``psychophysics.population``): the gain
field's population vector per flash and eye, through the eye-position signal; and its own looks at
the target in the displacement paradigm (the post-saccadic target read out under the gain field
that the feedback still holds around the goal's remapped position)."""

from __future__ import annotations

import math

import numpy as np

import models

from ..population import cortical_offset, feedback_strength, from_cortical_offset, population_estimate
from . import register
from .base import ConstantsTheory

__all__ = ["Population", "image_to_deg", "deg_to_image", "population_point", "remapped_point"]


def image_to_deg(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Image-plane points (complex, tan of eccentricity) as retinal positions in degrees (complex:
    eccentricity along the same direction), and the map's area factor (deg^2 per image-plane unit^2)."""
    z = np.asarray(z, complex)
    r = np.abs(z)
    ecc = np.degrees(np.arctan(r))
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(r > 0, ecc / np.where(r > 0, r, 1.0), math.degrees(1.0))
    radial = math.degrees(1.0) / (1.0 + r**2)
    return z * scale, radial * scale


def deg_to_image(zeta: complex) -> complex:
    """A retinal position in degrees (complex) back on the image plane."""
    r = abs(zeta)
    if not np.isfinite(r):
        return complex(np.nan, np.nan)
    return zeta * (math.tan(math.radians(r)) / r) if r > 0 else 0j


def population_point(z: complex, z_goal: complex, strength: float, p) -> complex:
    """The population vector's image point for a stimulus at image point ``z`` under the gain field
    of strength ``strength`` centred on the goal's image point ``z_goal`` (steps 1-5 of
    ``psychophysics.population`` with constants ``p``); NaN where the retina saw nothing."""
    if not (np.isfinite(z.real) and np.isfinite(z_goal.real)):
        return complex(np.nan, np.nan)
    goal = image_to_deg(np.array([z_goal]))[0][0]
    dw = complex(cortical_offset(image_to_deg(np.array([z]))[0][0], goal, p.map_a_deg))
    est = from_cortical_offset(population_estimate(dw, strength, p.rf_sd, p.field_sd), goal, p.map_a_deg)
    return deg_to_image(est)


def remapped_point(runner, e: int, z: complex, pose_from: tuple, pose_to: tuple) -> complex:
    """Eye ``e``'s image point, through the eye pose ``pose_to``, of the screen point seen at image
    point ``z`` through ``pose_from`` (poses as ``TrialRunner._pose`` gives them): the remapping of a
    retinal position by the change of eye pose; NaN where ``z`` is."""
    from ..trial import SCREEN_DISTANCE

    if not np.isfinite(z.real):
        return complex(np.nan, np.nan)
    (a_from, o_from), (a_to, o_to) = pose_from, pose_to
    az, el = np.radians(runner._ray_to_screen_deg(o_from[e], a_from[e], z))
    x = a_to[e].T @ (runner.head.to_head(models.screen_point(az, el, SCREEN_DISTANCE)) - o_to[e])
    return complex(x[2], x[0]) / x[1]


class Population(ConstantsTheory):
    """A gain-field population on the cortical map (``psychophysics.population``)."""

    name = "population"

    def read(self, runner, obs, plan, true_pose, cfg):
        """The population vector per flash and eye; ``gain`` is the gain field's strength."""
        pp = cfg.population
        strength = feedback_strength(plan, obs.t_mid, pp)
        axes, origins = runner._pose(plan.eye_position_signal(obs.t_mid + pp.latency_ms))
        reads = []
        for f in obs.flashes:
            per_eye, maps = [], runner.plain_maps(f, cfg.threshold)
            for e, (_, _, _, z_t, z_rel) in enumerate(maps):
                z_hat = population_point(z_t + z_rel, z_t, strength, pp)
                per_eye.append(
                    runner._ray_to_screen_deg(origins[e], axes[e], z_hat)
                    if np.isfinite(z_hat.real)
                    else np.full(2, np.nan)
                )
            reads.append((per_eye, per_eye, maps))
        return reads, strength, 0.0

    def displacement_looks(self, runner, plan, looks, cfg):
        """The target's head-centred positions (deg, mean of the eyes) before and after the saccade.
        Before it, the gain field is centred on the target itself (the goal), so its population
        vector is where the retina sees it. After it, the gain field -- of the strength the feedback
        still has when the post-saccadic response arrives (``feedback_strength``) -- is centred on
        the goal's remapped position (the pre-saccadic target carried into post-saccadic retinal
        coordinates by the efference copy of the saccade, as the goal of ``read`` is), so the
        population vector of the target seen after the saccade is pulled towards where the target
        was expected: a step is seen shrunk while the feedback lasts (Ziesche & Hamker 2014), and in
        full once it has decayed. Both looks through the eye-position signal at each response's
        arrival; the report's noise is ``report_noise_deg``."""
        pp = cfg.population
        (t_pre, zs_pre), (t_post, zs_post) = looks
        pose_pre = runner._pose(plan.eye_position_signal(t_pre + pp.latency_ms))
        pose_post = runner._pose(plan.eye_position_signal(t_post + pp.latency_ms))
        copies = [runner._pose(plan.intended_angles(t)) for t in (t_pre, t_post)]  # the efference copy
        s_post = feedback_strength(plan, t_post, pp)
        pre, post = [], []
        for e, (z_pre, z_post) in enumerate(zip(zs_pre, zs_post)):
            if not (np.isfinite(z_pre.real) and np.isfinite(z_post.real)):
                continue
            goal = remapped_point(runner, e, z_pre, *copies)
            pre.append(runner._ray_to_screen_deg(pose_pre[1][e], pose_pre[0][e], z_pre))
            z_hat = population_point(z_post, goal, s_post, pp)
            post.append(runner._ray_to_screen_deg(pose_post[1][e], pose_post[0][e], z_hat))
        if not pre:
            return np.full(2, np.nan), np.full(2, np.nan), cfg.report_noise_deg
        return np.mean(pre, axis=0), np.mean(post, axis=0), cfg.report_noise_deg


register(Population())
