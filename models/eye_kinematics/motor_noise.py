"""Saccadic motor error: scatter elongated along the saccade's direction, and undershoot.

Human saccade endpoints scatter in ellipses whose long axis lies along the saccade's direction:
the error in amplitude is larger than the error in direction (van Opstal & van Gisbergen 1989,
Vision Res 29:1183; van Beers 2007, J Neurosci 27:8757), and both grow in proportion to the
amplitude (signal-dependent noise). Primary saccades to a single target also fall short on average:
they cover about 90 % of the target's distance, a small corrective saccade doing the rest (Becker
1989, in Wurtz & Goldberg (eds.), The Neurobiology of Saccadic Eye Movements, pp. 13-67; Kapoula &
Robinson 1986, Vision Res 26:735, who showed the undershoot shrinks when accuracy is asked for).

Model: a saccade of cyclopean amplitude ``A`` from the fixation direction ``d0`` to the target
direction ``d1`` lands at the direction reached by turning ``d1`` about the saccade's axis
``n = d0 x d1`` by ``(gain - 1) A + along A z1`` (along the great circle, positive beyond the
target) and then about the direction of motion by ``across A z2``, with ``z1, z2`` standard normal
draws of the saccade's own generator. The executed amplitude's mean is ``gain A`` and its s.d.
``along A``; the s.d. across the direction is ``across A``.

Parameters (``HUMAN_MOTOR_NOISE``) and their sources:

=========  =====  =============================================================================
along      0.06   s.d. of the amplitude error / amplitude: 5-6 % of eccentricity for point targets
                  (Kowler & Blaser 1995, Vision Res 35:1741, abstract).
across     0.04   s.d. across the direction / amplitude: smaller than ``along``; the ellipses'
                  elongation is reported by van Opstal & van Gisbergen 1989 and van Beers 2007.
                  The value (an along/across ratio of 1.5) is this project's choice within those
                  reports, not a number read from them.
gain       0.90   mean executed / intended amplitude: the ~10 % undershoot of primary saccades
                  (Becker 1989; "about 90 % of the target distance", restated by Harris 1995,
                  Vision Res 35:691). Task-dependent (Kapoula & Robinson 1986).
=========  =====  =============================================================================

The default of ``models.Head`` is no motor error at all (``MotorNoise()``: a saccade lands on its
target), as it always was; ``HUMAN_MOTOR_NOISE`` is opted into.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from conformal import checks

__all__ = ["MotorNoise", "HUMAN_MOTOR_NOISE"]


@dataclass(frozen=True)
class MotorNoise:
    """Saccadic motor error (see the module docstring): ``along`` and ``across`` are the s.d. of the
    endpoint error along and across the saccade's direction as fractions of its amplitude (0-1 each),
    ``gain`` the mean executed / intended amplitude (0.5-1.5; 1 = no undershoot). The default is no
    error. ``isotropic`` is the older model (``Head(endpoint_noise=...)``): the same s.d. on the
    horizontal and vertical Fick angles of the endpoint."""

    along: float = 0.0
    across: float = 0.0
    gain: float = 1.0
    isotropic: bool = False

    def __post_init__(self):
        for name in ("along", "across"):
            object.__setattr__(self, name, checks.real(name, getattr(self, name), 0.0, 1.0,
                                                       hint="the s.d. as a fraction of the amplitude"))
        object.__setattr__(self, "gain", checks.real("gain", self.gain, 0.5, 1.5,
                                                     hint="mean executed / intended amplitude; 0.9 is a 10 % undershoot"))
        if not isinstance(self.isotropic, bool):
            raise checks.InputTypeError(f"isotropic must be True or False; got {type(self.isotropic).__name__}")
        if self.isotropic and (self.along != self.across or self.gain != 1.0):
            raise ValueError("an isotropic MotorNoise has along == across and gain 1; use MotorNoise.of(sd)")

    @classmethod
    def of(cls, sd: float) -> MotorNoise:
        """The isotropic error of ``Head(endpoint_noise=sd)``: s.d. ``sd`` x amplitude on each Fick angle."""
        sd = checks.real("sd", sd, 0.0, 1.0, hint="the s.d. of the endpoint error as a fraction of the amplitude")
        return cls(sd, sd, 1.0, True)

    @property
    def active(self) -> bool:
        """Whether a saccade's endpoint differs from its target (then each saccade draws two normals)."""
        return self.along > 0 or self.across > 0 or self.gain != 1.0

    def _directions(self, d0: np.ndarray, d1: np.ndarray, amp: np.ndarray, z: np.ndarray) -> np.ndarray:
        """Executed unit directions (m, 3) of saccades from the unit directions ``d0`` to ``d1`` (m, 3),
        of amplitudes ``amp`` (m,) (rad, > 0), with standard normal draws ``z`` (m, 2) (along, across)."""
        n = np.cross(d0, d1)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        a = ((self.gain - 1.0) + self.along * z[:, 0]) * amp
        c = self.across * z[:, 1] * amp
        t1 = np.cross(n, d1)  # the direction of motion at the target
        d = np.cos(a)[:, None] * d1 + np.sin(a)[:, None] * t1  # along the great circle through d0 and d1
        return np.cos(c)[:, None] * d - np.sin(c)[:, None] * n  # then across it


#: Human primary saccades (the module docstring's table).
HUMAN_MOTOR_NOISE = MotorNoise(along=0.06, across=0.04, gain=0.90)
