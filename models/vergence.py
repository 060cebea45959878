"""Vergence dynamics: the disjunctive part of a binocular gaze shift, slower than the saccade.

A gaze shift between targets at different distances has a conjugate (version) part, carried by
the saccade, and a disjunctive (vergence) part. Disparity vergence alone is slow and late: it starts
~160 ms after a disparity step and responses to steps of a few degrees take several hundred ms, with
a smooth, roughly bell-shaped velocity profile (Rashbass & Westheimer 1961, J Physiol 159:339;
Collewijn, Erkelens & Steinman 1995, Vision Res 35:3335). During a saccade vergence speeds up
several-fold (saccade-vergence interaction: Enright 1984, J Physiol 350:9; Zee, FitzGibbon &
Optican 1992, J Neurophysiol 68:1624), so much of a combined gaze shift's vergence happens
inside the saccade and the rest follows slowly.

Model (a vergence generator, not a first-order lag): the fraction ``r`` of the vergence change done
is the critically damped response ``r = 1 - (1 + s) e^-s`` of an internal time ``s``: velocity
``s e^-s`` (per unit of ``s``) is zero at the start, peaks at ``s = 1`` and decays -- a skewed bell.
``s`` runs at ``1 / tau_ms``; from burst onset to the saccade's offset it runs ``saccade_speedup``
times faster (the saccadic burst facilitates the vergence generator: Zee et al. 1992's omnipause
gating). Without a saccade (the version part below the 30 deg/s detection threshold) the response
starts ``latency_ms`` after the command's onset: disparity vergence's own latency. With a saccade
vergence starts with the burst (combined movements: Enright 1984).

Constants and their sources: ``latency_ms = 160`` (Rashbass & Westheimer 1961: ~160 ms);
``tau_ms = 90`` and ``saccade_speedup = 4`` are this project's choices within those reports (not
fits): a 2 deg vergence step without a saccade peaks at 8.2 deg/s 90 ms after it starts and is
90 % done 350 ms after it starts; inside a 20 deg saccade (~66 ms) about 79 % of it is done.

Not modelled: accommodation and its coupling to vergence, convergence/divergence asymmetries,
vertical vergence dynamics (vertical components move with the saccade), and Listing's plane
tilting with convergence (L2; Mok et al. 1992, Van Rijn & Van den Berg 1993): torsion obeys
Listing's law for each eye's own gaze direction at every instant (L1), as in the rest of
``models.eye_kinematics``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from conformal import checks

from ._plan_kernels import vergence_fraction, vergence_rate

__all__ = ["VergenceDynamics"]


@dataclass(frozen=True)
class VergenceDynamics:
    """The vergence generator with latency and saccadic facilitation (see the module docstring).

    tau_ms : time scale of the response outside saccades (10-2000 ms); velocity peaks ``tau_ms`` after
        the start.
    saccade_speedup : factor by which vergence is faster from burst onset to saccade offset (1-20).
    latency_ms : delay of a vergence without a saccade after the command's onset (0-1000 ms).
    """

    tau_ms: float = 90.0
    saccade_speedup: float = 4.0
    latency_ms: float = 160.0

    def __post_init__(self):
        object.__setattr__(self, "tau_ms", checks.real("tau_ms", self.tau_ms, 10.0, 2000.0))
        object.__setattr__(self, "saccade_speedup", checks.real("saccade_speedup", self.saccade_speedup, 1.0, 20.0))
        object.__setattr__(self, "latency_ms", checks.real("latency_ms", self.latency_ms, 0.0, 1000.0))

    def fraction(self, t_rel_ms, saccade_offset_ms) -> np.ndarray:
        """Fraction of the vergence change done ``t_rel_ms`` after burst onset (0 before it);
        ``saccade_offset_ms`` <= 0: no saccade."""
        return vergence_fraction(np.asarray(t_rel_ms, float), saccade_offset_ms, self.saccade_speedup, self.tau_ms,
                                 self.latency_ms)

    def rate(self, t_rel_ms, saccade_offset_ms) -> np.ndarray:
        """d fraction / dt (1/ms)."""
        return vergence_rate(np.asarray(t_rel_ms, float), saccade_offset_ms, self.saccade_speedup, self.tau_ms,
                             self.latency_ms)

    def settle_ms(self, change_deg, saccade_offset_ms, settle_deg: float):
        """Time after burst onset from which the remaining vergence change is below ``settle_deg``
        (arrays broadcast; a float for scalar arguments)."""
        from scipy.special import lambertw

        change = np.asarray(change_deg, float)
        offset = np.asarray(saccade_offset_ms, float)
        y = np.where(change > settle_deg, settle_deg / np.where(change > 0, change, 1.0), 1.0)
        # (1 + s) e^-s = y  <=>  s = -1 - W_-1(-y / e)
        s = np.where(y < 1.0, -1.0 - lambertw(-np.minimum(y, 1.0) / np.e, -1).real, 0.0)
        need = self.tau_ms * s  # internal time needed, in ms at the slow rate
        fast = np.maximum(offset, 0.0) * self.saccade_speedup
        out = np.where(need <= fast, need / self.saccade_speedup, np.maximum(offset, 0.0) + (need - fast))
        out = np.where(offset <= 0.0, self.latency_ms + need, out)
        out = np.where(change <= settle_deg, 0.0, out)
        return float(out) if out.ndim == 0 else out
