"""Saccadic motor error: scatter elongated along the saccade's direction, and undershoot.

Endpoints scatter in ellipses whose long axis lies along the saccade (van Opstal & van Gisbergen
1989, Vision Res 29:1183; van Beers 2007, J Neurosci 27:8757), both errors in proportion to the
amplitude; primary saccades cover about 90 % of the distance (Becker 1989; Kapoula & Robinson
1986, Vision Res 26:735).

Model: a saccade of cyclopean amplitude ``A`` from ``d0`` to the target direction ``d1`` lands at
``d1`` turned about ``n = d0 x d1`` by ``(gain - 1) A + along A z1`` and then about the direction of
motion by ``across A z2`` (``z1, z2`` standard normal draws of the saccade's own generator): mean
executed amplitude ``gain A``, s.d. ``along A`` along and ``across A`` across.

``HUMAN_MOTOR_NOISE`` = (along 0.06: Kowler & Blaser 1995, Vision Res 35:1741, 5-6 % of
eccentricity; across 0.04: an along/across ratio of 1.5, this project's choice within the
elongation reported above, not a number read from a paper; gain 0.90: Becker 1989, restated by
Harris 1995, Vision Res 35:691). The table with each source is in docs/head.md. The default of
``models.Head`` is no motor error (``MotorNoise()``); ``HUMAN_MOTOR_NOISE`` is opted into."""

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
            object.__setattr__(
                self,
                name,
                checks.real(name, getattr(self, name), 0.0, 1.0, hint="the s.d. as a fraction of the amplitude"),
            )
        object.__setattr__(
            self,
            "gain",
            checks.real(
                "gain", self.gain, 0.5, 1.5, hint="mean executed / intended amplitude; 0.9 is a 10 % undershoot"
            ),
        )
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
