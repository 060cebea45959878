"""Gymnasium environments: saccade actions in, remapped conformal-camera cortical observations out.

Importing ``envs`` registers ``BinocularSaccade-v0`` (and ``BinocularSaccadeSearch-v0``, the
``search`` task), so ``gymnasium.make("BinocularSaccade-v0", ...)`` works.
"""

import gymnasium as gym

from .display import compose_frame, grid_overlay
from .saccade_env import BinocularSaccadeEnv
from .tasks import TASKS, FixateTask, FreeViewingTask, SearchTask, Task, gaze_errors_deg, make_task
from .vision import REMAP_MODELS, EyeView, Vision, model_errors, normalized_error

__all__ = [
    "BinocularSaccadeEnv", "Vision", "EyeView", "REMAP_MODELS", "normalized_error", "model_errors",
    "Task", "FixateTask", "SearchTask", "FreeViewingTask", "TASKS", "make_task", "gaze_errors_deg",
    "compose_frame", "grid_overlay", "ENV_IDS",
]

ENV_IDS = ("BinocularSaccade-v0", "BinocularSaccadeSearch-v0")

if "BinocularSaccade-v0" not in gym.registry:
    gym.register(id="BinocularSaccade-v0", entry_point="envs.saccade_env:BinocularSaccadeEnv",
                 kwargs={"task": "fixate"})
    gym.register(id="BinocularSaccadeSearch-v0", entry_point="envs.saccade_env:BinocularSaccadeEnv",
                 kwargs={"task": "search"})
