"""The ``population`` perception model: a gain-field population on the cortical map.

The theory (Hamker, Zirnsak, Calow & Lappe 2008, PLoS Comput Biol 4:e31; the map's geometry as
in Richard, Churan, Guitton & Pack 2009, J Neurosci 29:10160): a retinotopic population tiles the
cortical map ``w = log(|zeta| + a) + i arg(zeta)`` (Schwartz 1980; ``a = map_a_deg``, Horton &
Hoyt 1991) uniformly; a flash evokes a Gaussian bump (s.d. ``rf_sd``) around its cortical position;
an oculomotor feedback signal (the burst through two first-order stages, ``tau_ms``) multiplies
the gain of the units around the saccade goal, ``g(w) = 1 + S exp(-|w - w_T|^2 / (2 field_sd^2))``
with ``S = gain_per_deg * s_bar``; the population vector ``integral(w g R) / integral(g R)`` (closed
form: ``population_estimate``) is read out through the eye-position signal. Compression is not
imposed: the gain field's gradient pulls every flash towards the goal. It has no term for visual
references (the same compression in the dark and with references). After the saccade the same
gain field, centred on the goal's remapped position with the feedback's decaying strength
(``feedback_strength``), pulls a displaced target towards where it was expected (Ziesche & Hamker
2014, Front Comput Neurosci 8:25): ``theories.population``'s displacement looks.

The five steps in full: docs/psychophysics/theories.md ("Rival theories", section "The population
model in full").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .bounds import check_constants

__all__ = [
    "PopulationParams",
    "POPULATION_SOURCES",
    "feedback_signal",
    "feedback_strength",
    "cortical_offset",
    "from_cortical_offset",
    "population_estimate",
]


@dataclass(frozen=True)
class PopulationParams:
    """Free constants of the ``population`` model (sources: ``POPULATION_SOURCES``)."""

    gain_per_deg: float = 150.0
    field_sd: float = 0.5
    rf_sd: float = 0.6
    tau_ms: float = 20.0
    latency_ms: float = 70.0
    response_ms: float = 50.0
    map_a_deg: float = 0.75

    def __post_init__(self) -> None:
        check_constants(self, may_be_zero=("gain_per_deg", "latency_ms"))


POPULATION_SOURCES = {
    "gain_per_deg": (
        "calibrated",
        "peak compression ~50 % for 20 deg saccades with references "
        "(Morrone, Ross & Burr 1997): phenomenon compression_peak",
    ),
    "field_sd": (
        "assumed",
        "gain field circumscribed around the goal on the cortical map, ~half the goal's "
        "eccentricity (Hamker et al. 2008, anisotropic magnification model)",
    ),
    "rf_sd": (
        "assumed",
        "the read-out layer's large receptive fields (Hamker et al. 2008's L2, LIP/TE-like: "
        "RF diameter ~ eccentricity), s.d. 0.6 on the log map",
    ),
    "tau_ms": ("assumed", "burst-like feedback (Hamker et al. 2008, Fig. 5) smoothed by the FEF/SC loop; 20 ms"),
    "latency_ms": ("assumed", "visual latency of a flash in extrastriate cortex ~70 ms (Schmolesky et al. 1998)"),
    "response_ms": ("assumed", "transient visual response to an 8 ms flash lasts ~50 ms (Schmolesky et al. 1998)"),
    "map_a_deg": ("assumed", "V1 foveal constant 0.75 deg (Horton & Hoyt 1991, Arch Ophthalmol 109:816)"),
}


_BURSTS: dict[int, tuple] = {}  # id(plan) -> (plan, times, burst): a plan's burst, reused across read-outs


def _burst(plan, t_end: float, dt_ms: float) -> tuple[np.ndarray, np.ndarray]:
    """The cyclopean efference-copy speed (deg/ms) on a ``dt_ms`` grid from just before onset to
    ``t_end`` (cached per plan: a fit reads the same plans out many times)."""
    hit = _BURSTS.get(id(plan))
    if hit is not None and hit[0] is plan and hit[1][-1] >= t_end and hit[1][1] - hit[1][0] == dt_ms:
        return hit[1], hit[2]
    t0 = float(plan.onset_ms) - 5.0
    grid = np.arange(t0, max(t_end, float(plan.end_ms) + 200.0, t0) + 2 * dt_ms, dt_ms)
    ang = np.degrees(plan.intended_angles(grid)[:, :, :2].mean(axis=1))
    burst = np.hypot(*np.gradient(ang, dt_ms, axis=0).T)
    if len(_BURSTS) > 4096:
        _BURSTS.clear()
    _BURSTS[id(plan)] = (plan, grid, burst)
    return grid, burst


def feedback_signal(plan, t_ms: np.ndarray, tau_ms: float, dt_ms: float = 0.5) -> np.ndarray:
    """The feedback signal (deg/ms) at times ``t_ms``: the burst (cyclopean efference-copy speed)
    through two first-order stages of time constant ``tau_ms`` (exact discretisation), from
    before the saccade."""
    from scipy.signal import lfilter

    t_ms = np.atleast_1d(np.asarray(t_ms, float))
    grid, burst = _burst(plan, float(t_ms.max()) + dt_ms, dt_ms)
    k = math.exp(-dt_ms / tau_ms)
    s = lfilter([1 - k], [1, -k], lfilter([1 - k], [1, -k], burst))
    return np.interp(t_ms, grid, s, left=0.0)


def feedback_strength(plan, t_ms: float, p: PopulationParams) -> float:
    """The gain field's strength ``S = gain_per_deg * s_bar`` for a stimulus that appears at
    ``t_ms``: ``s_bar`` the feedback signal averaged over its visual response (``latency_ms``
    after it, lasting ``response_ms``; 11 samples)."""
    t_resp = t_ms + p.latency_ms + np.linspace(0.0, p.response_ms, 11)
    return p.gain_per_deg * float(np.mean(feedback_signal(plan, t_resp, p.tau_ms)))


def cortical_offset(zeta_deg, goal_deg: complex, a: float) -> np.ndarray:
    """Cortical position (complex: log-eccentricity, polar angle) of retinal positions ``zeta_deg``
    (deg, complex) relative to the goal's, on the map ``w = log(|zeta| + a) + i arg(zeta)`` (the
    complex-log model with foveal constant ``a``, in polar form so that both hemifields lie on one
    sheet; polar angle wrapped to (-pi, pi])."""
    z = np.asarray(zeta_deg, complex)
    dr = np.log(np.abs(z) + a) - math.log(abs(goal_deg) + a)
    dth = np.angle(z * np.conj(goal_deg)) if abs(goal_deg) > 0 else np.angle(z)
    return dr + 1j * dth


def from_cortical_offset(dw: complex, goal_deg: complex, a: float) -> complex:
    """The retinal position (deg, complex) at cortical offset ``dw`` from the goal."""
    r = math.exp(dw.real + math.log(abs(goal_deg) + a)) - a
    th = dw.imag + (np.angle(goal_deg) if abs(goal_deg) > 0 else 0.0)
    return complex(max(r, 0.0) * np.exp(1j * th))


def population_estimate(dw_flash: complex, strength: float, rf_sd: float, field_sd: float) -> complex:
    """The population vector (cortical offset from the goal) of a continuum of units with Gaussian
    receptive fields (s.d. ``rf_sd`` on the map) responding to a flash at ``dw_flash``, with gains
    ``1 + strength exp(-|w|^2 / (2 field_sd^2))`` (the goal at 0): the integrals of Gaussian
    products in closed form,

        w_hat = (rf^2 w_f + S c^2 E w_c) / (rf^2 + S c^2 E),
        c^2 = rf^2 f^2 / (rf^2 + f^2),  w_c = w_f f^2 / (rf^2 + f^2),  E = exp(-|w_f|^2 / (2 (rf^2 + f^2)))."""
    rf2, f2 = rf_sd**2, field_sd**2
    c2 = rf2 * f2 / (rf2 + f2)
    e = strength * c2 * math.exp(-(abs(dw_flash) ** 2) / (2 * (rf2 + f2)))
    w_c = dw_flash * f2 / (rf2 + f2)
    return (rf2 * dw_flash + e * w_c) / (rf2 + e)
