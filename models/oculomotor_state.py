"""``OculomotorState``: the public state of one head's oculomotor system (``Head.get_state`` /
``Head.set_state``), what another engine or a saved trial needs to continue where the head is.

The physics (joint angles, velocities, actuator set-points) lives in the head's MuJoCo ``data``; this
is the rest: the clock, what the eyes and the eye-position signal hold between saccades, the
fixation point, the saccade in flight and the plan the signal follows, the random stream of the
endpoint noise and scene layouts, and which objects are shown (flashes and visibility changes).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .oculomotor import SaccadePlan

__all__ = ["OculomotorState"]


@dataclass
class OculomotorState:
    """One head's oculomotor state (see the module docstring).

    time_ms : the simulation clock, whole ms.
    hold : Fick angles (2, 3) [eye, (h, v, t)] the eyes hold between saccades (the last plan's
        executed endpoint).
    signal_hold : where the eye-position signal rests (2, 3) (the last plan's intended endpoint).
    fixation_head : the head-frame point (3,) the eyes fixate.
    rng : the head's random generator -- the object itself, not a copy: drawing from it advances the
        head's stream (endpoint noise, scene layouts).
    seed : the seed the head's random stream was last started from (``Head(seed=...)`` or
        ``Head.reset(seed=...)``; None: fresh entropy).
    plan : the saccade in flight (None between saccades).
    signal_plan : the plan the eye-position signal follows (None before the first saccade).
    last_plan : the last plan started (``Head.last_plan``).
    flashes : visible flashes, name -> the whole ms at which each hides.
    opacity : scene objects whose visibility ``set_visible`` / ``set_opacity`` changed, name -> alpha
        now (``set_state`` restores every other object to the scene's own).
    """

    time_ms: int
    hold: np.ndarray
    signal_hold: np.ndarray
    fixation_head: np.ndarray
    rng: np.random.Generator
    seed: int | None = None
    plan: SaccadePlan | None = None
    signal_plan: SaccadePlan | None = None
    last_plan: SaccadePlan | None = None
    flashes: dict[str, int] = field(default_factory=dict)
    opacity: dict[str, float] = field(default_factory=dict)

    def copy(self) -> OculomotorState:
        """A copy whose arrays and dicts are new (the generator and the plans are shared)."""
        return OculomotorState(
            int(self.time_ms),
            self.hold.copy(),
            self.signal_hold.copy(),
            self.fixation_head.copy(),
            self.rng,
            self.seed,
            self.plan,
            self.signal_plan,
            self.last_plan,
            dict(self.flashes),
            dict(self.opacity),
        )
