"""The ``population`` theory's read-out (the model: ``psychophysics.population``): the gain
field's population vector per flash and eye, through the eye-position signal."""

from __future__ import annotations

import math

import numpy as np

from ..population import cortical_offset, feedback_signal, from_cortical_offset, population_estimate
from . import register
from .base import ConstantsTheory

__all__ = ["Population", "image_to_deg", "deg_to_image"]


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


class Population(ConstantsTheory):
    """A gain-field population on the cortical map (``psychophysics.population``)."""

    name = "population"

    def read(self, runner, obs, plan, true_pose, cfg):
        """The population vector per flash and eye; ``gain`` is the gain field's strength."""
        pp = cfg.population
        t_resp = obs.t_mid + pp.latency_ms + np.linspace(0.0, pp.response_ms, 11)
        strength = pp.gain_per_deg * float(np.mean(feedback_signal(plan, t_resp, pp.tau_ms)))
        axes, origins = runner._pose(plan.eye_position_signal(obs.t_mid + pp.latency_ms))
        reads = []
        for f in obs.flashes:
            per_eye, maps = [], runner.plain_maps(f, cfg.threshold)
            for e, (_, _, _, z_t, z_rel) in enumerate(maps):
                z = z_t + z_rel
                goal = image_to_deg(np.array([z_t]))[0][0]
                dw = complex(cortical_offset(image_to_deg(np.array([z]))[0][0], goal, pp.map_a_deg))
                est = (
                    from_cortical_offset(population_estimate(dw, strength, pp.rf_sd, pp.field_sd), goal, pp.map_a_deg)
                    if np.isfinite(dw.real)
                    else complex(np.nan, np.nan)
                )
                z_hat = deg_to_image(est)
                per_eye.append(
                    runner._ray_to_screen_deg(origins[e], axes[e], z_hat)
                    if np.isfinite(z_hat.real)
                    else np.full(2, np.nan)
                )
            reads.append((per_eye, per_eye, maps))
        return reads, strength, 0.0


register(Population())
