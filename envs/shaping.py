"""Potential-based reward shaping for the saccade tasks (Ng, Harada & Russell 1999, ICML).

:class:`PotentialShaping` wraps a ``BinocularSaccadeEnv`` (directly or under other Gymnasium
wrappers) of a task with a target and adds F = gamma * Phi(s') - Phi(s) to each step's reward,
with the potential Phi(s) = -e(s) / ``scale_deg``, e the mean gaze error (deg) of the two eyes to the
target. On a *termination* (the target foveated) Phi(s') = 0, the absorbing terminal state of Ng et
al.'s theorem, so for every policy the discounted shaped return is

    sum_t gamma^t r'_t = sum_t gamma^t r_t - Phi(s_0)                          (terminated)
    sum_t gamma^t r'_t = sum_t gamma^t r_t + gamma^T Phi(s_T) - Phi(s_0)       (truncated)

-Phi(s_0) does not depend on the policy, and a truncation is bootstrapped by the learner from
V(s_T), which absorbs the gamma^T Phi(s_T) term (Ng et al., Theorem 1): the optimal policy under
``gamma`` is unchanged. What the task measures (its success, tolerance and ``reward_*``
components) is unchanged; the shaping term is reported as ``info["reward_shaping"]`` and the task's
own reward as ``info["reward_task"]``. ``gamma`` must be the learner's discount for the guarantee.

Off by default (the env's rewards are the task's); the training recipes' hyper-parameter files say
when they turn it on (``experiments/hyperparams/``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, cast

import gymnasium as gym

from conformal import checks

from .tasks import _gaze_errors_deg

if TYPE_CHECKING:
    import models

    from .tasks import Task

__all__ = ["PotentialShaping"]


class _TargetEnv(Protocol):
    """What the shaping reads of the unwrapped env (a ``BinocularSaccadeEnv``): its head and task."""

    head: models.Head
    task: Task


class PotentialShaping(gym.Wrapper):
    """Add gamma * Phi(s') - Phi(s), Phi = -(mean gaze error to the target) / ``scale_deg``, to the
    reward of a saccade env with a target task (``fixate``, ``search``). ``gamma`` in (0, 1]: the
    learner's discount; ``scale_deg`` in (0, 180]: the error that is worth one unit of potential."""

    def __init__(self, env: gym.Env, gamma: float = 0.9, scale_deg: float = 10.0) -> None:
        if not isinstance(env, gym.Env):
            raise checks.InputTypeError(
                f"env must be a gymnasium.Env (a BinocularSaccadeEnv); got {type(env).__name__}"
            )
        base = env.unwrapped
        if not (hasattr(base, "head") and hasattr(base, "task")):
            raise checks.InputTypeError(f"env must wrap a BinocularSaccadeEnv; got {type(base).__name__}")
        if base.task.name == "free":
            raise ValueError("env's task 'free' has no target and so no gaze-error potential; use 'fixate' or 'search'")
        super().__init__(env)
        self.gamma = checks.real("gamma", gamma, 0.0, 1.0, lo_open=True)
        self.scale_deg = checks.real("scale_deg", scale_deg, 0.0, 180.0, lo_open=True)
        self._phi: float | None = None

    def potential(self) -> float:
        """Phi of the current state: -(mean gaze error to the target, deg) / ``scale_deg``."""
        base = cast(_TargetEnv, self.env.unwrapped)  # checked in __init__: it has head and task
        err = _gaze_errors_deg(base.head, base.task.target_position(base.head))
        return -float(err.mean()) / self.scale_deg

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        self._phi = self.potential()
        return obs, info

    def step(self, action):
        if self._phi is None:
            raise RuntimeError("call reset() before step()")
        obs, reward, terminated, truncated, info = self.env.step(action)
        phi_next = 0.0 if terminated else -float(info["target_error_deg"]) / self.scale_deg
        shaping = self.gamma * phi_next - self._phi
        self._phi = phi_next
        info = {**info, "reward_task": float(reward), "reward_shaping": shaping}
        return obs, float(reward) + shaping, terminated, truncated, info
