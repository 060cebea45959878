"""The ``mechanistic`` theory (``psychophysics.mechanisms``: every ingredient and its source): the
efference-copy remapping driven by the oculomotor command, read out through the eye-position signal
and anchored on the post-saccadic references by a weight graded by their retinal activity; each
ingredient switchable by ``TrialConfig.disabled``."""

from __future__ import annotations

import math

import numpy as np

from ..mechanisms import MECHANISMS, command_gain
from . import register
from .base import Theory
from .shift import shift_read

__all__ = ["Mechanistic"]


class Mechanistic(Theory):
    """The composite of switchable mechanisms (``mechanisms.MECHANISMS``)."""

    name = "mechanistic"
    switchable = MECHANISMS

    def describe(self, cfg) -> list[str]:
        """The remapping's drive, the reference weight and the ingredients switched off."""
        off = ", ".join(cfg.disabled) or "none"
        return [
            f"remapping driven by the eye-position signal's speed x {cfg.feedback_gain:g} ms/deg; "
            f"reference weight {cfg.reference_weight:g}; mechanisms off: {off}"
        ]

    def read(self, runner, obs, plan, true_pose, cfg):
        """Two routes per flash: the anchored one (the remapped offset from the seen anchor) and the
        extraretinal one (unremapped, through the eye-position signal), mixed by the reference weight."""
        on = self.mechanisms_on(cfg)
        t_read = obs.t_mid + (cfg.visual_latency_ms if on["latency"] else 0.0)  # when its response arrives
        gain = command_gain(plan, t_read, cfg.feedback_gain) if on["command_remap"] else 0.0
        if cfg.eye_position == "signal" and on["eye_position_signal"]:
            read_angles = plan.eye_position_signal(t_read)
        else:
            read_angles = plan.angles(obs.t_mid)
        read_pose = runner._pose(read_angles)  # eye-position estimate: retinal -> head
        seen, weight = self.anchor(runner, obs, plan, cfg) if on["references"] else (None, 0.0)
        reads = [
            shift_read(runner, f, gain, weight, seen, obs.copy_pose, read_pose, true_pose, cfg.threshold, True)
            for f in obs.flashes
        ]
        return reads, gain, weight

    def anchor(self, runner, obs, plan, cfg) -> tuple[np.ndarray, float]:
        """The post-saccadic anchor (each eye's head-centred position, deg, of what stands for the
        goal: the target where the retina sees it, else the centroid of the references it sees)
        through the settled eye-position signal, and the anchored route's weight, graded by the
        references' retinal activity A (target, ruler and markers together, as rendered):
        ``reference_weight x min(1, A / reference_unit)``."""
        act = obs.ref_activity if obs.ref_activity is not None else np.zeros(2)
        finite = np.isfinite(act)
        a = float(np.mean(act[finite])) if finite.any() else 0.0
        weight = cfg.reference_weight * min(max(a, 0.0) / cfg.reference_unit, 1.0)
        axes, origins = runner._pose(plan.eye_position_signal(float(obs.t_post)))
        refs = obs.ref_z if obs.ref_z is not None else [complex(np.nan, np.nan)] * 2
        target_seen = all(np.isfinite(z.real) for z in obs.seen_z)
        seen = np.full((2, 2), np.nan)
        for e, z in enumerate(obs.seen_z if target_seen else refs):
            if np.isfinite(z.real):
                seen[e] = runner._ray_to_screen_deg(origins[e], axes[e], z)
        if not np.all(np.isfinite(seen)):
            return seen, 0.0  # nothing seen to anchor on
        return seen, weight

    def stability_weight(self, cfg, mismatch_deg: float, amplitude_deg: float, on: dict) -> float:
        """A target seen at landing within the range of normal landing errors (``stability_tolerance``
        x amplitude, as a Gaussian weight) is taken as stable (Deubel, Schneider & Bridgeman 1996)."""
        if not (on["references"] and np.isfinite(mismatch_deg)):
            return 0.0
        tol = cfg.stability_tolerance * amplitude_deg
        return cfg.reference_weight * math.exp(-0.5 * (mismatch_deg / tol) ** 2) if tol > 0 else 0.0


register(Mechanistic())
