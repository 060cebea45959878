"""models: the MuJoCo binocular head, its scenes, off-screen eye rendering and the oculomotor plant
(saccade generator, vergence, eye-position signal).

``MUJOCO_GL`` defaults to ``egl`` when unset (set on ``import models``, before MuJoCo is imported).
The public names load on first use (PEP 562): ``import models`` imports no MuJoCo, so pure-numpy
code can use ``models.eye_kinematics`` (the formulas that need no MuJoCo) without it.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from ._gl_default import set_default_backend

set_default_backend()

#: The submodule each public name lives in (imported when the name is first used); its keys are ``__all__``.
_HOMES: dict[str, str] = {
    **dict.fromkeys(("GLBackendError", "gl_install_hint"), "_gl"),
    **dict.fromkeys(
        (
            "DEFAULT_FOVY_DEG",
            "DEFAULT_IPD",
            "HEAD_XML",
            "QUALITIES",
            "ModelFileError",
            "build_model",
            "build_spec",
            "export_xml",
            "load_model",
        ),
        "build",
    ),
    **dict.fromkeys(("VISUAL_LATENCY_MS", "EyePositionSignal"), "eye_position_signal"),
    **dict.fromkeys(
        (
            "MAX_PEAK_VELOCITY",
            "MAX_PEAK_VELOCITY_DEG_S",
            "MainSequence",
            "OculomotorRangeError",
            "fick_angles",
            "fick_matrix",
            "fixation_angles",
            "gaze_direction",
            "listing_torsion",
            "rotation_vector",
            "cyclopean_amplitude",
            "displaced",
            "fixation_batch",
            "MotorNoise",
            "HUMAN_MOTOR_NOISE",
        ),
        "eye_kinematics",
    ),
    **dict.fromkeys(("SACCADE_MODELS", "SaccadePlan"), "oculomotor"),
    **dict.fromkeys(("EYES", "EyeImage", "EyeRenderer", "ForkedGLContextError", "StereoFrame"), "render"),
    **dict.fromkeys(("PLANTS", "BurstGenerator", "SaccadeProfile"), "saccade_generator"),
    **dict.fromkeys(("CYCLOPEAN_EYE", "SCENES", "SceneInfo", "screen_point"), "scenes"),
    **dict.fromkeys(("DEFAULT_SACCADE_TIMESTEP_MS", "DEFAULT_TIMESTEP_MS", "servo_setpoints"), "servo"),
    **dict.fromkeys(("EyeState", "EyeTrace", "Head"), "simulation"),
    **dict.fromkeys(("VergenceDynamics",), "vergence"),
    **dict.fromkeys(("OculomotorState",), "oculomotor_state"),
    **dict.fromkeys(("Profiles", "SaccadePlans", "profiles"), "saccade_plans"),
    **dict.fromkeys(("BatchedPlanner", "SettledReset", "plan_clipped"), "planner"),
    **dict.fromkeys(("EYE_DRIVES", "OrbitalPlant"), "plant"),
    **dict.fromkeys(("LinearTail",), "linear_tail"),
    **dict.fromkeys(("limit_plan_threads",), "_plan_kernels"),
    **dict.fromkeys(("time_kernel_paths",), "plan_kernel_timing"),
}

__all__ = list(_HOMES)

if TYPE_CHECKING:  # what type checkers and IDEs see; at run time the names load on first use (below)
    from ._gl import GLBackendError, gl_install_hint
    from ._plan_kernels import limit_plan_threads
    from .build import (
        DEFAULT_FOVY_DEG,
        DEFAULT_IPD,
        HEAD_XML,
        QUALITIES,
        ModelFileError,
        build_model,
        build_spec,
        export_xml,
        load_model,
    )
    from .eye_kinematics import (
        HUMAN_MOTOR_NOISE,
        MAX_PEAK_VELOCITY,
        MAX_PEAK_VELOCITY_DEG_S,
        MainSequence,
        MotorNoise,
        OculomotorRangeError,
        cyclopean_amplitude,
        displaced,
        fick_angles,
        fick_matrix,
        fixation_angles,
        fixation_batch,
        gaze_direction,
        listing_torsion,
        rotation_vector,
    )
    from .eye_position_signal import VISUAL_LATENCY_MS, EyePositionSignal
    from .linear_tail import LinearTail
    from .oculomotor import SACCADE_MODELS, SaccadePlan
    from .oculomotor_state import OculomotorState
    from .plan_kernel_timing import time_kernel_paths
    from .planner import BatchedPlanner, SettledReset, plan_clipped
    from .plant import EYE_DRIVES, OrbitalPlant
    from .render import EYES, EyeImage, EyeRenderer, ForkedGLContextError, StereoFrame
    from .saccade_generator import PLANTS, BurstGenerator, SaccadeProfile
    from .saccade_plans import Profiles, SaccadePlans, profiles
    from .scenes import CYCLOPEAN_EYE, SCENES, SceneInfo, screen_point
    from .servo import DEFAULT_SACCADE_TIMESTEP_MS, DEFAULT_TIMESTEP_MS, servo_setpoints
    from .simulation import EyeState, EyeTrace, Head
    from .vergence import VergenceDynamics


def __getattr__(name: str):
    """A public name (from its home in ``_HOMES``) or a submodule (``models.scenes``) on first use."""
    home = _HOMES.get(name)
    if home is None:
        if name.startswith("__"):
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
        try:
            return importlib.import_module(f"{__name__}.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":
                raise
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    value = getattr(importlib.import_module(f"{__name__}.{home}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
