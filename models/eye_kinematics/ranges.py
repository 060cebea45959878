"""The oculomotor range and what lies outside it: the joint ranges of the Fick gimbal, the speed
ceiling, the nearest fixation distance, the null saccade, and the error for an unreachable target.
"""

from __future__ import annotations

import numpy as np

from conformal import checks

__all__ = [
    "H_RANGE",
    "V_RANGE",
    "T_RANGE",
    "MAX_PEAK_VELOCITY",
    "MAX_PEAK_VELOCITY_DEG_S",
    "MIN_TARGET_DISTANCE",
    "NULL_SACCADE",
    "OculomotorRangeError",
    "check_point",
]

H_RANGE = np.deg2rad(45.0)  #: horizontal oculomotor range (+-), radians
V_RANGE = np.deg2rad(35.0)  #: vertical oculomotor range (+-), radians
T_RANGE = np.deg2rad(20.0)  #: Fick-torsion joint range (+-); Listing torsion stays below 15 deg
#: Ceiling of eye speed (deg/s): a bound of the model family, not of people. Human saccades saturate
#: near 500 deg/s on average (Collewijn, Erkelens & Steinman 1988, J Physiol 404:157: 502 +- 32 deg/s
#: for 40 deg and larger), individuals and video trackers reach 600-800 deg/s (Boghen et al. 1974;
#: hand-labelled EyeLink saccades at 540-690 deg/s for 13-20 deg), so a generator fitted to a fast
#: person must be allowed past 700 deg/s. The ceiling is the eye-tracker reader's plausibility limit
#: (``experiments.eyetracking.MAX_PLAUSIBLE_VELOCITY_DEG_S``, the same number, tested): every saccade a
#: recording may keep can be represented, and anything faster is an artefact.
MAX_PEAK_VELOCITY_DEG_S = 1000.0
MAX_PEAK_VELOCITY = np.deg2rad(MAX_PEAK_VELOCITY_DEG_S)  #: the ceiling in rad/s
MIN_TARGET_DISTANCE = 0.05  #: metres from an eye's rotation centre
#: Saccades no larger than this (rad) are null: no endpoint noise is drawn for them (their amplitude
#: is an arccos near 1, where the last bit of a dot product moves it by ~1e-8 rad)
NULL_SACCADE = 1e-7


class OculomotorRangeError(ValueError):
    """A fixation target the eyes cannot reach (outside +-45 deg horizontal / +-35 deg vertical,
    closer than 5 cm, behind the head) or not a finite 3-vector."""


def check_point(p, name: str = "target") -> np.ndarray:
    """``p`` as a finite 3-vector (metres); :class:`OculomotorRangeError` otherwise."""
    p = checks.array(name, p, kinds="biuf", finite=False).astype(float)
    if p.shape != (3,):
        raise OculomotorRangeError(f"{name} must be a 3-vector (x, y, z) in metres, got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise OculomotorRangeError(f"{name} must be finite, got {p.tolist()}")
    return p
