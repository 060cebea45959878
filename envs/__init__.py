"""Gymnasium environments: saccade actions in, remapped conformal-camera cortical observations out.

Importing ``envs`` registers ``BinocularSaccade-v0`` (and ``BinocularSaccadeSearch-v0``, the
``search`` task), so ``gymnasium.make("BinocularSaccade-v0", ...)`` works; each with
``max_episode_steps`` equal to its task's default saccade budget (5 and 10 steps, where the env truncates
its episodes itself: Gymnasium's ``TimeLimit`` truncates at the same step); their vector entry point
is ``BatchedBinocularSaccade`` (``gymnasium.make_vec(..., vectorization_mode="vector_entry_point")``),
which needs the ``gpu`` extra (imported on first use: without it the single env is unchanged).
"""

import gymnasium as gym

from .batched_env import BatchedBinocularSaccade
from .batched_shaping import BatchedPotentialShaping
from .display import compose_frame, grid_overlay
from .saccade_env import BinocularSaccadeEnv
from .shaping import PotentialShaping
from .tasks import TASKS, FixateTask, FreeViewingTask, SearchTask, Task, gaze_errors, gaze_errors_deg, make_task
from .vision import REMAP_MODELS, EyeView, Vision, model_errors, normalized_error

__all__ = [
    "BinocularSaccadeEnv",
    "BatchedBinocularSaccade",
    "Vision",
    "EyeView",
    "REMAP_MODELS",
    "normalized_error",
    "model_errors",
    "Task",
    "FixateTask",
    "SearchTask",
    "FreeViewingTask",
    "TASKS",
    "make_task",
    "gaze_errors_deg",
    "gaze_errors",
    "compose_frame",
    "grid_overlay",
    "ENV_IDS",
    "PotentialShaping",
    "BatchedPotentialShaping",
]

ENV_IDS = ("BinocularSaccade-v0", "BinocularSaccadeSearch-v0")

if "BinocularSaccade-v0" not in gym.registry:
    for _id, _task in zip(ENV_IDS, ("fixate", "search")):
        gym.register(
            id=_id,
            entry_point="envs.saccade_env:BinocularSaccadeEnv",
            vector_entry_point="envs.batched_env:BatchedBinocularSaccade",
            kwargs={"task": _task},
            max_episode_steps=TASKS[_task].max_saccades,
        )  # the task's default budget: 5, 10
