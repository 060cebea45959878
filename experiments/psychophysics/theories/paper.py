"""The ``paper`` theory (``psychophysics.mechanisms``): the paper's §6.5 as first built -- the
log-radius shift of the target-centred map by a gain that follows a hand-set time course
(``TrialConfig.timecourse``), read out through the eye-position signal at the flash's arrival."""

from __future__ import annotations

from . import register
from .base import Theory
from .shift import shift_read

__all__ = ["Paper"]


class Paper(Theory):
    """The set-curve model, kept by name for comparison (its time course is an input)."""

    name = "paper"
    uses_timecourse = True

    def read(self, runner, obs, plan, true_pose, cfg):
        """The shifted map's centroid through the eye-position signal (or the true eye, with
        ``eye_position="true"``) at the flash's arrival; ``gain`` = the time course at the flash."""
        t_read = obs.t_mid + cfg.visual_latency_ms  # when its response arrives
        gain = float(cfg.timecourse.gain(obs.trial.flash_time_ms))
        angles = plan.eye_position_signal(t_read) if cfg.eye_position == "signal" else plan.angles(obs.t_mid)
        read_pose = runner._pose(angles)  # eye-position estimate: retinal -> head
        reads = [
            shift_read(runner, f, gain, 0.0, None, obs.copy_pose, read_pose, true_pose, cfg.threshold, False)
            for f in obs.flashes
        ]
        return reads, gain, 0.0


register(Paper())
