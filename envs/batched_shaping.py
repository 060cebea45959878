"""Potential-based reward shaping for the batched env (``BatchedBinocularSaccade``), world by world.

The shaping of :class:`envs.PotentialShaping` (Ng, Harada & Russell 1999): F = gamma * Phi(s') - Phi(s),
Phi(s) = -e(s) / ``scale_deg`` with e the mean gaze error (deg) of both eyes to the target, and Phi = 0
after a termination (the absorbing terminal state of the theorem). Here it is kept beside the batched
env rather than wrapped around it: the learner calls :meth:`BatchedPotentialShaping.start` after a
reset and :meth:`~BatchedPotentialShaping.step` after each step, which returns F for every world and,
for the worlds the env reset within that step (``autoreset_mode="same_step"``), takes their new
episode's Phi. The env's own rewards, successes and infos are unchanged.
"""

from __future__ import annotations

import numpy as np

from conformal import checks

__all__ = ["BatchedPotentialShaping"]


class BatchedPotentialShaping:
    """F = gamma * Phi(s') - Phi(s) per world of ``env`` (a ``BatchedBinocularSaccade`` with a target
    task and ``autoreset_mode="same_step"``); ``gamma`` in (0, 1]: the learner's discount."""

    def __init__(self, env, gamma: float = 0.9, scale_deg: float = 10.0) -> None:
        from gymnasium.vector import AutoresetMode

        if not (hasattr(env, "task") and hasattr(env, "num_envs") and hasattr(env, "autoreset_mode")):
            raise checks.InputTypeError(f"env must be a BatchedBinocularSaccade; got {type(env).__name__}")
        if env.task.name == "free":
            raise ValueError("task 'free' has no target and so no gaze-error potential; use 'fixate' or 'search'")
        if env.autoreset_mode is not AutoresetMode.SAME_STEP:
            raise ValueError("BatchedPotentialShaping needs the env's autoreset_mode='same_step'")
        self.env = env
        self.gamma = checks.real("gamma", gamma, 0.0, 1.0, lo_open=True)
        self.scale_deg = checks.real("scale_deg", scale_deg, 0.0, 180.0, lo_open=True)
        self.phi = np.zeros(env.num_envs)

    def potential(self) -> np.ndarray:
        """Phi of every world's current state (N,): -(mean gaze error to the target, deg) / ``scale_deg``."""
        n = self.env.num_envs
        err, _ = self.env._gaze_errors(None, np.empty(0, np.int64), np.zeros(n, bool))  # (N, 2), as info reports
        return -err.mean(axis=1) / self.scale_deg

    def start(self) -> None:
        """After ``env.reset``: every world's Phi(s_0)."""
        self.phi = self.potential()

    def step(self, info: dict, terminated: np.ndarray, done: np.ndarray) -> np.ndarray:
        """F (N,) of the step whose ``info``, ``terminated`` and ``done`` (terminated | truncated) are
        given; the ended worlds' Phi is then their new episode's."""
        phi_next = np.where(terminated, 0.0, -np.asarray(info["target_error_deg"], np.float64) / self.scale_deg)
        f = self.gamma * phi_next - self.phi
        self.phi = np.where(done, self.potential(), phi_next) if np.any(done) else phi_next
        return f
