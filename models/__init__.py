"""models: the MuJoCo binocular head, its scenes, off-screen eye rendering and the oculomotor plant
(saccade generator, vergence, eye-position signal).

``MUJOCO_GL`` defaults to ``egl`` when unset (set before MuJoCo is imported).
"""

from ._gl import GLBackendError, gl_install_hint
from .build import (DEFAULT_FOVY_DEG, DEFAULT_IPD, HEAD_XML, QUALITIES, ModelFileError, build_model,
                    build_spec, export_xml, load_model)
from .eye_position_signal import VISUAL_LATENCY_MS, EyePositionSignal
from .eye_kinematics import (MAX_PEAK_VELOCITY, MainSequence, OculomotorRangeError, fick_angles, fick_matrix,
                             fixation_angles, gaze_direction, listing_torsion, rotation_vector)
from .oculomotor import SACCADE_MODELS, SaccadePlan
from .render import EYES, EyeImage, EyeRenderer, ForkedGLContextError, StereoFrame
from .saccade_generator import PLANTS, BurstGenerator, SaccadeProfile
from .scenes import CYCLOPEAN_EYE, SCENES, SceneInfo, screen_point
from .servo import DEFAULT_SACCADE_TIMESTEP_MS, DEFAULT_TIMESTEP_MS
from .simulation import EyeState, EyeTrace, Head
from .vergence import VergenceDynamics
from .eye_kinematics import cyclopean_amplitude, displaced, fixation_batch
from .oculomotor_state import OculomotorState
from .saccade_plans import Profiles, SaccadePlans, profiles
from .planner import BatchedPlanner, SettledReset, plan_clipped
from .servo import servo_setpoints
from .plant import EYE_DRIVES, OrbitalPlant
from ._plan_kernels import limit_plan_threads

__all__ = [
    "limit_plan_threads",
    "SCENES", "QUALITIES", "EYES", "DEFAULT_FOVY_DEG", "DEFAULT_IPD", "HEAD_XML", "CYCLOPEAN_EYE",
    "MAX_PEAK_VELOCITY", "DEFAULT_TIMESTEP_MS", "DEFAULT_SACCADE_TIMESTEP_MS",
    "build_model", "build_spec", "export_xml", "load_model", "screen_point",
    "Head", "EyeState", "EyeTrace", "SceneInfo",
    "EyeRenderer", "EyeImage", "StereoFrame",
    "SACCADE_MODELS", "BurstGenerator", "SaccadeProfile", "PLANTS", "VergenceDynamics", "EyePositionSignal",
    "VISUAL_LATENCY_MS", "MainSequence", "SaccadePlan", "fixation_angles", "listing_torsion", "fick_matrix", "fick_angles",
    "gaze_direction", "rotation_vector", "OculomotorState", "SaccadePlans", "Profiles", "profiles",
    "BatchedPlanner", "SettledReset", "plan_clipped", "servo_setpoints", "OrbitalPlant", "EYE_DRIVES", "fixation_batch", "displaced", "cyclopean_amplitude",
    "GLBackendError", "ForkedGLContextError", "ModelFileError", "OculomotorRangeError", "gl_install_hint",
]
