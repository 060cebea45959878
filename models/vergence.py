"""Vergence dynamics: the disjunctive part of a binocular gaze shift, slower than the saccade.

A vergence generator, not a first-order lag: the fraction of the vergence change done is the
critically damped response ``r = 1 - (1 + s) e^-s`` of an internal time ``s`` (velocity zero at the
start, a skewed bell peaking at ``s = 1``). ``s`` runs at ``1 / tau_ms`` (``divergence_tau_ms`` for
divergence, slower: Hung, Zhu & Ciuffreda 1997, Vision Res 37:1197; Alvarez, Semmlow & Pedrono 2005,
Vision Res 45:1847), and ``saccade_speedup`` times faster from burst onset to the saccade's offset
(Enright 1984, J Physiol 350:9; Zee, FitzGibbon & Optican 1992, J Neurophysiol 68:1624). Without a
saccade it starts ``latency_ms`` after the command (Rashbass & Westheimer 1961, J Physiol 159:339);
with one, with the burst. The command is the target's disparity (open-loop); outside saccades the
peak velocity is ``change / (e tau)``, a linear main sequence.

Constants: ``latency_ms = 160`` (Rashbass & Westheimer 1961); ``tau_ms = 90``,
``divergence_tau_ms = 135`` and ``saccade_speedup = 4`` are this project's choices within those
reports, not fits. Their consequences, the sources in full and what is not modelled (accommodation,
Listing's plane tilting with convergence, ...): docs/head.md ("Head and oculomotor", section
"Vergence").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from conformal import checks

from ._plan_kernels import vergence_fraction, vergence_rate

__all__ = ["VergenceDynamics"]


@dataclass(frozen=True)
class VergenceDynamics:
    """The vergence generator: disparity-driven, with latency, saccadic facilitation and convergence
    faster than divergence (see the module docstring).

    tau_ms : time scale of a convergence outside saccades (10-2000 ms); velocity peaks ``tau_ms`` after
        the start.
    saccade_speedup : factor by which vergence is faster from burst onset to saccade offset (1-20).
    latency_ms : delay of a vergence without a saccade after the command's onset (0-1000 ms).
    divergence_tau_ms : time scale of a divergence (10-2000 ms; at least ``tau_ms``: convergence is
        the faster).
    """

    tau_ms: float = 90.0
    saccade_speedup: float = 4.0
    latency_ms: float = 160.0
    divergence_tau_ms: float = 135.0

    def __post_init__(self):
        object.__setattr__(self, "tau_ms", checks.real("tau_ms", self.tau_ms, 10.0, 2000.0))
        object.__setattr__(self, "saccade_speedup", checks.real("saccade_speedup", self.saccade_speedup, 1.0, 20.0))
        object.__setattr__(self, "latency_ms", checks.real("latency_ms", self.latency_ms, 0.0, 1000.0))
        object.__setattr__(
            self, "divergence_tau_ms", checks.real("divergence_tau_ms", self.divergence_tau_ms, 10.0, 2000.0)
        )
        if self.divergence_tau_ms < self.tau_ms:
            raise ValueError(
                f"divergence_tau_ms ({self.divergence_tau_ms:g}) must be at least tau_ms "
                f"({self.tau_ms:g}): convergence is faster than divergence (Hung, Zhu & Ciuffreda 1997)"
            )

    def _tau_for(self, convergence) -> np.ndarray:
        """The time scale (ms) of a vergence change ``convergence`` (> 0 converging, < 0 diverging)."""
        return np.where(np.asarray(convergence, float) >= 0, self.tau_ms, self.divergence_tau_ms)

    def fraction(self, t_rel_ms, saccade_offset_ms, converging: bool = True) -> np.ndarray:
        """Fraction of the vergence change done ``t_rel_ms`` after burst onset (0 before it);
        ``saccade_offset_ms`` <= 0: no saccade."""
        return vergence_fraction(
            np.asarray(t_rel_ms, float), saccade_offset_ms, self.saccade_speedup, self._tau(converging), self.latency_ms
        )

    def rate(self, t_rel_ms, saccade_offset_ms, converging: bool = True) -> np.ndarray:
        """d fraction / dt (1/ms)."""
        return vergence_rate(
            np.asarray(t_rel_ms, float), saccade_offset_ms, self.saccade_speedup, self._tau(converging), self.latency_ms
        )

    def peak_velocity_deg_s(self, change_deg) -> np.ndarray:
        """Peak velocity (deg/s) of a vergence change of ``change_deg`` (> 0 converging) without a
        saccade: ``|change| / (e tau)`` (the main sequence of the module docstring)."""
        change = checks.array("change_deg", change_deg).astype(float)
        return np.abs(change) / (np.e * self._tau_for(change)) * 1000.0

    def _tau(self, converging: bool) -> float:
        if not isinstance(converging, (bool, np.bool_)):
            raise checks.InputTypeError(f"converging must be True or False; got {type(converging).__name__}")
        return self.tau_ms if converging else self.divergence_tau_ms

    def settle_ms(self, change_deg, saccade_offset_ms, settle_deg: float):
        """Time after burst onset from which the remaining vergence change is below ``settle_deg``
        (``change_deg`` > 0 converging, < 0 diverging; arrays broadcast; a float for scalar arguments)."""
        from scipy.special import lambertw

        signed = np.asarray(change_deg, float)
        change = np.abs(signed)
        tau = self._tau_for(signed)
        offset = np.asarray(saccade_offset_ms, float)
        y = np.where(change > settle_deg, settle_deg / np.where(change > 0, change, 1.0), 1.0)
        # (1 + s) e^-s = y  <=>  s = -1 - W_-1(-y / e)
        s = np.zeros(np.shape(y))
        moving = y < 1.0  # (W only where a change is left: the batched planner asks for thousands at once)
        s[moving] = -1.0 - lambertw(-y[moving] / np.e, -1).real
        need = tau * s  # internal time needed, in ms at the slow rate
        fast = np.maximum(offset, 0.0) * self.saccade_speedup
        out = np.where(need <= fast, need / self.saccade_speedup, np.maximum(offset, 0.0) + (need - fast))
        out = np.where(offset <= 0.0, self.latency_ms + need, out)
        out = np.where(change <= settle_deg, 0.0, out)
        return float(out) if out.ndim == 0 else out
