"""eye_kinematics: the oculomotor formulas that need no MuJoCo -- Fick angles and Listing's law
(``fick``), the oculomotor range (``ranges``), binocular fixation geometry of N heads at once
(``fixation``), saccadic motor error (``motor_noise``) and the legacy analytic main sequence (``main_sequence``).

Numpy (and the compiled kernels of ``models._plan_kernels``) only: pure-numpy code can import it
without MuJoCo. Angles are radians unless a name ends in ``_deg``; times are milliseconds.
"""

from .fick import (
    PRIMARY_EYE_BASIS,
    eye_frame_basis,
    fick_angles,
    fick_matrix,
    gaze_direction,
    listing_torsion,
    rotation_vector,
    with_listing,
)
from .fixation import cyclopean_amplitude, displaced, fixation_angles, fixation_batch, noisy_endpoints
from .main_sequence import MainSequence
from .motor_noise import HUMAN_MOTOR_NOISE, MotorNoise
from .ranges import (
    H_RANGE,
    MAX_PEAK_VELOCITY,
    MAX_PEAK_VELOCITY_DEG_S,
    MIN_TARGET_DISTANCE,
    NULL_SACCADE,
    T_RANGE,
    V_RANGE,
    OculomotorRangeError,
    check_point,
)

__all__ = [
    "PRIMARY_EYE_BASIS",
    "fick_matrix",
    "fick_angles",
    "gaze_direction",
    "listing_torsion",
    "with_listing",
    "rotation_vector",
    "eye_frame_basis",
    "fixation_angles",
    "fixation_batch",
    "displaced",
    "cyclopean_amplitude",
    "noisy_endpoints",
    "MainSequence",
    "MotorNoise",
    "HUMAN_MOTOR_NOISE",
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
