"""The extraretinal eye-position signal: the brain's estimate of where each eye points.

Perisaccadic flashes in darkness are mislocalized in the direction of the saccade from about
100 ms before it, and against it after it, as if the retinal position of the flash were combined
with an eye-position signal that changes slowly, starting well before the saccade and settling
well after it (Matin & Pearce 1965, Science 148:1485; Honda 1991, Vision Res 31:1915; Dassonville,
Schlag & Schlag-Rey 1992, Vis Neurosci 9:261 -- "a damped representation of saccadic eye
displacement"; Pola 2004, Vision Res 44:2799).

Model: the signal is the efference copy -- the *intended* trajectory of the saccade, noise-free --
smoothed by a Gaussian of s.d. ``sigma_ms`` and delayed by ``delay_ms``:

    EPS(t) = start + (intended_end - start) * (G_sigma * s)(t - delay),

with ``s`` the normalised command profile of the saccade generator. It is the signal *at the
comparator*, at time ``t``; a flash at time ``t_f`` reaches the comparator after the visual
latency ``L`` (``models.VISUAL_LATENCY_MS``) and is paired with ``EPS(t_f + L)``. With the defaults
(sigma 50 ms, delay 50 ms, L = 70 ms), in flash time the signal starts to change about 100 ms
before saccade onset, is half-way near onset and reaches 95 % about 100 ms after onset, after
the saccade has ended: the time course Honda (1991) and Dassonville et al. (1992) inferred. At the comparator it starts changing ~30 ms
before the saccade and reaches its new value after the saccade has ended. Torsion follows
Listing's law for the signal's own gaze direction.

Because the signal comes from the intended command, it ends on the intended endpoint: after a
noisy saccade it differs from the true eye by the motor error, as it should (no oracle).
"""

from __future__ import annotations

from dataclasses import dataclass

from conformal import checks

__all__ = ["EyePositionSignal", "VISUAL_LATENCY_MS"]

#: Delay from a flash to its cortical response (ms): ~70 ms for a brief bright flash in human
#: visual cortex (onset latencies of the VEP/V1 response of roughly 50-80 ms; e.g. Schmolesky et
#: al. 1998, J Neurophysiol 79:3272, in macaque V1 ~66 ms).
VISUAL_LATENCY_MS = 70.0


@dataclass(frozen=True)
class EyePositionSignal:
    """Timing of the eye-position signal (see the module docstring).

    sigma_ms : s.d. of the Gaussian smoothing of the efference copy (1-500 ms).
    delay_ms : delay of the smoothed signal at the comparator (-500 to 500 ms).
    """

    sigma_ms: float = 50.0
    delay_ms: float = 50.0

    def __post_init__(self):
        object.__setattr__(self, "sigma_ms", checks.real("sigma_ms", self.sigma_ms, 1.0, 500.0))
        object.__setattr__(self, "delay_ms", checks.real("delay_ms", self.delay_ms, -500.0, 500.0))
