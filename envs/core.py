"""The env core: what ``BinocularSaccadeEnv`` and ``BatchedBinocularSaccade`` share, written once.

The single env (one head, numpy) and the batched env (N worlds, torch on a device) are adapters over
these: the reset checks and the heads' seeds, the spaces, the observation's entries, the ``info`` of a
reset and of a step (its keys, their order, the saccade's and the task's entries), the end of an
episode (termination on the task's success, truncation by the saccade budget) and the refusal to be
copied. The batched env adds gymnasium's ``_key`` masks to the same ``info`` (:func:`masked`); each
backend computes the arrays.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from gymnasium import spaces

from conformal import checks

__all__ = [
    "MAX_FIXATION_MS",
    "SACCADE_INFO",
    "action_space",
    "check_options",
    "check_seed",
    "episode_end",
    "head_seed",
    "masked",
    "no_copy",
    "observation",
    "observation_space",
    "require_reset",
    "reset_info",
    "saccade_budget",
    "saccade_info",
    "step_info",
    "task_info",
    "world_seeds",
]

#: The longest fixation after a saccade (ms): 10 s, far beyond human fixations (180-320 ms).
MAX_FIXATION_MS = 10_000
#: The largest seed a head's reset draws (exclusive): a head is reset with ``rng.integers(HEAD_SEEDS)``.
HEAD_SEEDS = 2**31 - 1

_NO_COPY = (
    "a {} cannot be pickled or copied (pickle, copy.deepcopy, copy.copy): it holds a compiled MuJoCo "
    "model and an OpenGL context. Make a new env with the same arguments instead (gymnasium.make(env.spec.id, "
    "**env.spec.kwargs) for one made by gymnasium.make, else the class with the same keyword arguments); for the "
    "same state, reset the new env with the same seed and replay the same actions (the env is deterministic "
    "under a seed)"
)

#: The saccade's entries of a step's ``info``: key -> (shape per world, its value from a ``models.SaccadePlan``
#: or a batch of them, ``models.SaccadePlans``). A world that made no saccade reports zeros and identities.
SACCADE_INFO = {
    "saccade_amplitude_deg": ((), lambda p: np.rad2deg(p.amplitude)),
    "saccade_duration_ms": ((), lambda p: p.duration_ms),
    "peak_velocity_deg_s": ((), lambda p: np.degrees(p.peak_velocity)),
    "endpoint_error_deg": ((2,), lambda p: p.endpoint_error_deg),
    "efference_copy": ((2, 3, 3), lambda p: p.efference_copy),
    "executed_rotation": ((2, 3, 3), lambda p: p.executed_rotation),
}


# ---------------------------------------------------------------------------------------- reset
def check_seed(seed: Any, hint: str = "or None") -> int | None:
    """A reset's seed: None or an integer >= 0 (``hint`` ends the error message)."""
    return None if seed is None else checks.integer("seed", seed, 0, None, hint=hint)


def world_seeds(seed: Any, n: int) -> list[int | None]:
    """Each of ``n`` worlds' reset seed: None (all None), an int s (s, s + 1, ..., as gymnasium's
    ``SyncVectorEnv`` seeds its sub-envs) or a list of ``n`` seeds (each None or an int >= 0)."""
    if seed is None:
        return [None] * n
    if isinstance(seed, (list, tuple)):
        if len(seed) != n:
            raise ValueError(f"seed must be an int, None or a list of {n} seeds (one per world); got {len(seed)}")
        return [check_seed(s) for s in seed]
    s0 = check_seed(seed, hint="or None, or a list of one seed per world")
    assert s0 is not None  # seed is not None here
    return [s0 + i for i in range(n)]


def check_options(options: Any) -> None:
    """A reset's options: None or an empty dict (the env takes none)."""
    if options is not None and not isinstance(options, dict):
        raise checks.InputTypeError(f"options must be a dict or None; got {type(options).__name__}")
    if options:
        raise ValueError(f"this environment takes no reset options; got {', '.join(map(str, options))}")


def head_seed(rng: np.random.Generator) -> int:
    """The seed of a head's reset (its motor noise), drawn from the episode's generator."""
    return int(rng.integers(HEAD_SEEDS))


def require_reset(ready: bool, what: str = "step()") -> None:
    """Refuse ``what`` before the first reset."""
    if not ready:
        raise RuntimeError(f"call reset() before {what}")


def no_copy(cls_name: str, make: str = "gymnasium.make") -> TypeError:
    """The error that pickle and copy raise: what to do instead (``make``: the function that builds the env)."""
    return TypeError(_NO_COPY.format(cls_name).replace("gymnasium.make(", make + "("))


# ---------------------------------------------------------------------------------------- spaces
def observation_space(grid, channels: int, cortex: str, include_coeffs: bool) -> spaces.Dict:
    """One world's observation space (M rings, N sectors, N_f foveal samples of ``grid``; C = ``channels``):
    ``cortical`` and ``remapped`` (2, M, N, C), or (2, 2, M, N/2, C) with ``cortex="hemispheres"``,
    ``fovea`` (2, N_f, C), ``eyes`` (2, 3), and ``coeffs`` (2, M, N, C, 2) with ``include_coeffs``."""
    cort_shape = (2, grid.M, grid.N, channels) if cortex == "eyes" else (2, 2, grid.M, grid.N // 2, channels)
    obs: dict[str, spaces.Space] = {
        "cortical": spaces.Box(0.0, 1.0, cort_shape, np.float32),
        "fovea": spaces.Box(0.0, 1.0, (2, grid.n_fovea, channels), np.float32),
        "remapped": spaces.Box(0.0, 1.0, cort_shape, np.float32),
        "eyes": spaces.Box(-math.pi, math.pi, (2, 3), np.float32),
    }
    if include_coeffs:
        obs["coeffs"] = spaces.Box(-np.inf, np.inf, (2, grid.M, grid.N, channels, 2), np.float32)
    return spaces.Dict(obs)


def action_space(action_mode: str, vergence: bool, grid) -> spaces.Space:
    """One world's action space: ``Box(-1, 1, (2,))`` (``(3,)`` with vergence) or ``Discrete(M N)`` (cells)."""
    if action_mode == "vector":
        return spaces.Box(-1.0, 1.0, (3 if vergence else 2,), np.float32)
    return spaces.Discrete(grid.M * grid.N)


def observation(cortical, fovea, remapped, eyes, coeffs=None) -> dict:
    """The observation's entries in their order (arrays or tensors the env computed; ``coeffs`` only with
    ``include_coeffs``)."""
    obs = {"cortical": cortical, "fovea": fovea, "remapped": remapped, "eyes": eyes}
    if coeffs is not None:
        obs["coeffs"] = coeffs
    return obs


# ---------------------------------------------------------------------------------------- info
def reset_info(sim_time_ms, remap_error: dict) -> dict[str, Any]:
    """A reset's info: the clock and each remapping model's error (0: nothing predicted yet)."""
    return {"sim_time_ms": sim_time_ms, "remap_error": remap_error}


def saccade_info(plan) -> dict[str, Any]:
    """The saccade's entries (:data:`SACCADE_INFO`) of one ``models.SaccadePlan``: floats and array copies
    (the batched env fills its worlds' arrays from a ``models.SaccadePlans`` through the same table)."""
    return {k: get(plan).copy() if shape else float(get(plan)) for k, (shape, get) in SACCADE_INFO.items()}


def task_info(success, parts: dict, target_error_deg=None) -> dict[str, Any]:
    """The task's entries of a step's info, in order: ``target_error_deg`` (tasks with a target; None:
    none), ``success``, the reward's components ``reward_*`` (``Task.reward_keys``)."""
    head = {} if target_error_deg is None else {"target_error_deg": target_error_deg}
    return {**head, "success": success, **parts}


def step_info(
    sim_time_ms, remap_error: dict, saccade: dict, landing_error_deg, eye_angles, clipped, task_info: dict
) -> dict[str, Any]:
    """A step's info, keys in order: ``sim_time_ms``, ``remap_error``, the saccade's entries (``saccade``,
    :func:`saccade_info`) with ``landing_error_deg`` after the kinematics, ``eye_angles``, ``clipped``, then
    the task's (``target_error_deg`` where the task has a target, ``success``, the reward's ``reward_*``)."""
    s = saccade
    return {
        "sim_time_ms": sim_time_ms,
        "remap_error": remap_error,
        "saccade_amplitude_deg": s["saccade_amplitude_deg"],
        "saccade_duration_ms": s["saccade_duration_ms"],
        "peak_velocity_deg_s": s["peak_velocity_deg_s"],
        "landing_error_deg": landing_error_deg,
        "endpoint_error_deg": s["endpoint_error_deg"],
        "efference_copy": s["efference_copy"],
        "executed_rotation": s["executed_rotation"],
        "eye_angles": eye_angles,
        "clipped": clipped,
        **task_info,
    }


def masked(info: dict[str, Any], active: np.ndarray) -> dict[str, Any]:
    """``info`` of N worlds with gymnasium's ``_key`` mask after each key (nested dicts too): all True
    for the clock and the remapping errors (reported in every world), ``active`` for the rest."""
    every = np.ones(len(active), bool)
    out: dict[str, Any] = {}
    for k, v in info.items():
        mask = every if k in ("sim_time_ms", "remap_error") else active
        out[k] = {**v, **{"_" + m: mask.copy() for m in v}} if isinstance(v, dict) else v
        out["_" + k] = mask.copy()
    return out


# ---------------------------------------------------------------------------------------- episode end
def saccade_budget(max_saccades: int, max_episode_steps: Any = None) -> int:
    """The steps after which an episode is truncated: the task's ``max_saccades``, capped at
    ``max_episode_steps`` K >= 1 as gymnasium's ``TimeLimit(K)`` would cap it (None or -1: no cap)."""
    if max_episode_steps is None or max_episode_steps == -1:  # gymnasium.make's -1: no TimeLimit
        return max_saccades
    k = checks.integer(
        "max_episode_steps", max_episode_steps, 1, None, hint="or -1 or None: no limit beyond the task's max_saccades"
    )
    return min(max_saccades, k)


def episode_end(success, saccades, budget: int, active=True) -> tuple[Any, Any]:
    """(terminated, truncated) after a step (scalars or arrays of worlds): terminated where the task
    succeeded, truncated where it did not and the episode has used its saccade ``budget``; both False
    where not ``active`` (a world being reset)."""
    terminated = np.logical_and(active, success)
    truncated = np.logical_and(active, ~terminated) & (np.asarray(saccades) >= budget)
    return terminated, truncated
