"""The perception models of the flash trials: ``paper`` (a set time course) and ``mechanistic``.

``paper`` is the paper's §6.5 as this project first built it: the log-radius shift of the
target-centred map by a gain g(t) that follows a hand-set time course (``RemapTimeCourse``), the
result read out through the eye-position signal.

``mechanistic`` (the default) has no time course of its own. Its ingredients, each of which can be
switched off by name (``TrialConfig(disabled=(...))``, ``--disable``):

- ``smear``: the flash's image integrated over its 8 ms on the moving retina;
- ``latency``: the flash's cortical response meets the oculomotor signals ``visual_latency_ms``
  (70 ms) later;
- ``eye_position_signal``: retinal positions become head positions through the extraretinal
  eye-position signal (Honda 1991; Dassonville, Schlag & Schlag-Rey 1992), not the true eye;
- ``command_remap``: the §6.5 log-radius shift towards the saccade target with the gain
  ``g = feedback_gain * |dEPS/dt|``, the oculomotor feedback of Hamker, Zirnsak, Calow & Lappe
  (2008), PLoS Comput Biol 4:e31; ``feedback_gain`` (4.5 ms/deg) is calibrated to the ~50 % peak
  compression of a 20 deg saccade (Morrone, Ross & Burr 1997; Kaiser & Lappe 2004);
- ``references``: post-saccadic references anchor the read-out in the remapped, target-centred map
  (Lappe, Awater & Krekelberg 2000; Awater & Lappe 2006), weighted
  ``reference_weight x min(1, A / reference_unit)`` by the references' retinal activity A.

No fitted time course, no reference-dependent remapping, no Bayesian weighting of the two routes,
no perisaccadic suppression. Each ingredient in full: docs/psychophysics/run.md ("Flash
localization", section "The perception models in full").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MODELS", "CONDITIONS", "PARADIGMS", "MECHANISMS", "command_gain"]

#: Perception models of ``TrialConfig.model``.
MODELS = ("mechanistic", "paper", "population", "observer")
#: Viewing conditions of ``TrialConfig.condition``.
CONDITIONS = ("references", "dark")
#: Paradigms of ``TrialConfig.paradigm``.
PARADIGMS = ("localization", "separation", "displacement")
#: Ingredients of the mechanistic model that ``TrialConfig.disabled`` can switch off.
MECHANISMS = ("smear", "latency", "eye_position_signal", "command_remap", "references")


def command_gain(plan, t_ms: float, feedback_gain: float) -> float:
    """``feedback_gain * |dEPS/dt|`` at absolute time ``t_ms``: the speed (deg/ms) of the eye-position
    signal's cyclopean (mean of both eyes) horizontal/vertical change, by a central difference."""
    e = plan.eye_position_signal(np.array([t_ms - 0.5, t_ms + 0.5]))[:, :, :2].mean(axis=1)
    return float(feedback_gain * np.degrees(np.hypot(*(e[1] - e[0]))))


@dataclass(frozen=True)
class Routes:
    """The two read-out routes of a mechanistic trial and their weight (for recordings and tests)."""

    anchored: np.ndarray  #: (2,) deg: the reference-anchored, remapped estimate
    extraretinal: np.ndarray  #: (2,) deg: through the eye-position signal, unremapped
    weight: float  #: of the anchored route
