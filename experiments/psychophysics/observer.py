"""The ``observer`` perception model: perisaccadic localization as optimal (Bayesian) inference.

The theory (Niemeier, Crawford & Tweed 2003, Nature 422:76; Teichert, Klingenhoefer, Wachtler &
Bremmer 2010, J Vis 10(8):19; Binda, Cicchini, Burr & Morrone 2009, J Neurosci 29:13147): the
perceived head-centred position of a flash is the posterior mean of its position given

1. **the retinal evidence** -- the flash's retinal position ``r`` (the activity centroid of the
   retina's response, unremapped), with Gaussian sensory noise of s.d.
   ``sigma_r = floor_deg + weber * eccentricity`` (positional uncertainty grows with eccentricity:
   White, Levi & Aitsebaomo 1992, Vision Res 32:513; Levi, Klein & Aitsebaomo 1985);
2. **an eye-position signal with its own uncertainty** -- the brain knows the eye's trajectory from
   the efference copy ``c(t)`` but not exactly when the flash happened relative to it: the flash's
   time is known to s.d. ``temporal_sd_ms`` (Teichert et al. 2010; Binda et al. 2009). The eye
   position the flash is paired with is therefore uncertain, with mean and covariance

       e_hat(t) = E[c(t')],  Sigma_e(t) = Cov[c(t')],  t' ~ N(t, temporal_sd_ms^2)      (1)

   (Gauss-Hermite quadrature). Both follow from the saccade's own trajectory: ``Sigma_e`` is ~0
   during fixation and grows around the saccade, only along its direction, by an amount set by
   its amplitude and duration. The flash's measured head position is ``m = r (+) e_hat`` (the ray
   through the retinal point from the eyes at ``e_hat``), with likelihood covariance
   ``Sigma_r + Sigma_e``, the eye-position error shared by every flash of a trial;
3. **the visual references present after the saccade** -- the post-saccadic scene offers
   landmarks, and flashes are inferred to lie near them (a prior centred on the references'
   seen position ``rho``; the "attraction to the saccade target" of Binda et al. 2009, centred on
   what is actually seen there). Its precision grows with how much reference the retina saw:

       lambda = A / (prior_sd_deg^2 * reference_unit) * min(on_ms, integration_ms) / integration_ms   (2)

   with ``A`` the retina's activity of the post-saccadic references (their contrast and size, as
   rendered) and the temporal factor Bloch's law of temporal integration. No references (the
   dark, a memory-guided saccade with nothing else lit): ``lambda = 0``, a flat prior.

The posterior mean of k simultaneous flashes' positions ``h`` (per axis, Gaussian, closed form):

    h = (Lambda + C^-1)^-1 (Lambda rho 1 + C^-1 m),  C = diag(sigma_r^2) + sigma_e^2 1 1^T,  Lambda = lambda I   (3)

Compression (the percept pulled towards ``rho``), its time course and its anisotropy follow from
(1): only when ``Sigma_e`` is large is the prior's weight large, and only along the saccade.
The shift in the dark follows from ``e_hat`` leading the eye before and lagging it after the
saccade. Separation is spared because the eye-position error is common to both flashes of (3).
Displacement detection (``displacement_report``) compares the target's position before and after
the saccade; its noise is the model's own (1)+(sensory), so the threshold rises where
``Sigma_e`` is large -- at landing, not after a blank.

The model has one eye-position signal (1) for every condition and no branch on condition,
paradigm or blank: references, blanks and markers act only through what the eyes see and when.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .bounds import check_constants

__all__ = ["ObserverParams", "OBSERVER_SOURCES", "eye_estimate", "posterior_mean", "prior_precision",
           "sensory_sd_deg"]


@dataclass(frozen=True)
class ObserverParams:
    """Free constants of the ``observer`` model (sources: ``OBSERVER_SOURCES``)."""

    temporal_sd_ms: float = 40.0
    prior_sd_deg: float = 4.0
    weber: float = 0.05
    floor_deg: float = 0.1
    integration_ms: float = 100.0
    reference_unit: float = 8.4e-3

    def __post_init__(self) -> None:
        check_constants(self, may_be_zero=("floor_deg",))


#: name -> (role, source): ``calibrated`` constants were set from the named published number (which
#: then cannot count as reproduced); ``assumed`` ones come from other measurements.
OBSERVER_SOURCES = {
    "temporal_sd_ms": ("assumed", "uncertainty of a flash's time re the saccade: perisaccadic temporal "
                                  "misjudgements of 50-100 ms (Binda et al. 2009), temporal-order JNDs ~20-40 ms "
                                  "(Hirsh & Sherrick 1961); 40 ms taken between them"),
    "prior_sd_deg": ("calibrated", "peak compression ~50 % for 20 deg saccades with references "
                                   "(Morrone, Ross & Burr 1997): phenomenon compression_peak"),
    "weber": ("assumed", "flash localization s.d. ~5 % of eccentricity without references "
                         "(White, Levi & Aitsebaomo 1992, Vision Res 32:513)"),
    "floor_deg": ("assumed", "foveal positional acuity ~0.1 deg (Levi, Klein & Aitsebaomo 1985)"),
    "integration_ms": ("assumed", "Bloch's law: complete temporal summation up to ~100 ms (Barlow 1958)"),
    "reference_unit": ("assumed", "the unit of reference activity: the retina's summed response (image-plane "
                                  "area x intensity) to the default references (target dot + ruler at full "
                                  "contrast), measured at 256 px (tests/test_perception_theories.py)"),
}

# Gauss-Hermite nodes for E[f(t')], t' ~ N(t, s^2): t' = t + sqrt(2) s x_k, weights w_k / sqrt(pi)
_GH_X, _GH_W = np.polynomial.hermite.hermgauss(64)
_GH_W = _GH_W / math.sqrt(math.pi)


def eye_estimate(plan, t_ms: float, temporal_sd_ms: float) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (1): the mean efference-copy eye angles (2 eyes x 3 Fick angles, rad) over the flash's
    uncertain time, and the covariance (2 x 2, deg^2) of the cyclopean horizontal and vertical
    eye angle over it."""
    ts = float(t_ms) + math.sqrt(2.0) * float(temporal_sd_ms) * _GH_X
    a = plan.intended_angles(ts)  # (K, 2, 3)
    mean = np.tensordot(_GH_W, a, axes=1)
    cyc = np.degrees(a[:, :, :2].mean(axis=1))  # (K, 2): horizontal, vertical (deg)
    d = cyc - _GH_W @ cyc
    cov = (d * _GH_W[:, None]).T @ d
    return mean, cov


def sensory_sd_deg(eccentricity_deg: float | np.ndarray, p: ObserverParams) -> np.ndarray:
    """The retinal evidence's s.d. (deg) at an eccentricity (deg)."""
    return p.floor_deg + p.weber * np.abs(np.asarray(eccentricity_deg, float))


def prior_precision(activity: float, on_ms: float, p: ObserverParams) -> float:
    """Eq. (2): the references' prior precision (1/deg^2) from their retinal activity and on-time."""
    a = max(float(activity), 0.0) if np.isfinite(activity) else 0.0
    temporal = min(max(float(on_ms), 0.0), p.integration_ms) / p.integration_ms
    return a / p.reference_unit * temporal / p.prior_sd_deg**2


def posterior_mean(m: np.ndarray, sensory_var: np.ndarray, eye_var: float, rho: float, lam: float) -> np.ndarray:
    """Eq. (3) on one axis: the posterior mean positions of k flashes measured at ``m`` (k,) with
    independent sensory variances (k,), a shared eye-position variance and the prior N(rho, 1/lam)
    on each (``lam`` = 0: flat)."""
    m = np.asarray(m, float)
    C = np.diag(np.asarray(sensory_var, float)) + float(eye_var) * np.ones((m.size, m.size))
    P = np.linalg.inv(C)
    A = lam * np.eye(m.size) + P
    b = P @ m + (lam * rho if lam > 0 else 0.0)
    return np.linalg.solve(A, b)
