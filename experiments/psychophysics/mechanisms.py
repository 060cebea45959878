"""The perception models of the flash trials: ``paper`` (a set time course) and ``mechanistic``.

``paper`` is the paper's §6.5 as this project first built it: the log-radius shift of the
target-centred map by a gain g(t) that follows a hand-set time course (``RemapTimeCourse``), the
result read out through the eye-position signal.

``mechanistic`` (the default) has no time course of its own. Its ingredients, each of which can be
switched off by name (``TrialConfig(disabled=(...))``, ``--disable``):

``smear``
    the flash's retinal image is the integral over its 8 ms on the moving retina
    (``models.Head.render(exposure_ms=...)``); off: one render at the flash's onset.
``latency``
    the flash's cortical response arrives ``visual_latency_ms`` (70 ms) after it and meets the
    oculomotor signals of that moment; off: they are read at the flash's own time.
``eye_position_signal``
    retinal positions become head positions through the extraretinal eye-position signal
    (``models.SaccadePlan.eye_position_signal``), which leads the eye before the saccade and lags
    it after (Honda 1991; Dassonville, Schlag & Schlag-Rey 1992); off: through the true eye.
``command_remap``
    the efference-copy remapping of §6.5 -- the DPFT log-radius shift of the target-centred map
    towards the saccade target -- is driven by the oculomotor command itself: its gain is
    ``g = feedback_gain * |dEPS/dt|``, the speed (deg/ms) at which the eye-position signal, the
    smoothed efference copy, is changing when the flash's response arrives. This is the role of
    the oculomotor feedback signal in Hamker, Zirnsak, Calow & Lappe (2008), PLoS Comput Biol
    4:e31 (a saccade-locked, smoothly rising and decaying signal that shifts the gain of the
    retinotopic map towards the saccade target), taken from the saccade generator rather than
    drawn: its strength grows with amplitude (and weakly with velocity), its time course is the
    signal's. ``feedback_gain`` (4.5 ms/deg) is the one calibrated constant: a 20 deg saccade's
    peak compression is then ~50 %, the published peak (Morrone, Ross & Burr 1997; Kaiser & Lappe
    2004). Off: g = 0.
``references``
    post-saccadic visual references anchor the read-out (Lappe, Awater & Krekelberg 2000; Awater &
    Lappe 2006): when the post-saccadic retina sees a reference (the lit target, the ruler), the
    flash is localized *relative to it* in the remapped, target-centred map -- the seen target's
    head position (through the settled eye-position signal) plus the flash's compressed offset
    from the target -- so the eye-position signal's error cancels and compression shows. Without
    a reference (``condition="dark"``: the target goes off at saccade onset, the screen is black)
    only the extraretinal route is left: the flash's unremapped retinal position through the
    eye-position signal, which shifts but does not compress. The weight of the anchored route is
    graded by how much reference the retina sees: ``reference_weight x min(1, A / reference_unit)``,
    with A the retina's summed activity of every post-saccadic reference (target, ruler, markers;
    their contrast and size as rendered) and ``reference_unit`` the activity of the default
    references (target + ruler at full contrast, 256 px: the same measured unit as the observer's).
    The anchor is the seen target, or, where the target is not seen, the centroid of the references
    that are. Off: weight 0.

What the mechanistic model does not contain (so does not claim): any fitted time course, a
reference-dependent change of the remapping itself, a Bayesian weighting of the two routes by
their reliabilities (the weight is set), or the perisaccadic suppression of sensitivity.
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
