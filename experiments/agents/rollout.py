"""Running policies on ``BinocularSaccadeEnv`` in cell-action mode: episodes and evaluation."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .policies import Policy

__all__ = [
    "DEFAULT_ENV_KWARGS",
    "EVAL_STREAM",
    "TRAIN_STREAM",
    "VALIDATION_STREAM",
    "OBS_KEYS",
    "Evaluation",
    "episode_seeds",
    "evaluate",
    "make_env",
    "run_episode",
]

# image_size=96: at 64 px the ~1 deg target dot often vanishes from the pooled retina samples
# (the brightest-cell heuristic reaches the target in one saccade 30% of the time vs 90% at 96 px).
DEFAULT_ENV_KWARGS: dict[str, Any] = {
    "action_mode": "cell",
    "image_size": 96,
    "remap_models": ["homography"],
    "cortex": "eyes",
    "grayscale": False,
}
EVAL_STREAM, TRAIN_STREAM = 0, 1
#: The validation episodes of every trainer (CEM, SB3, batched PPO): neither the training nor the held-out ones.
VALIDATION_STREAM = 2
#: The observations the cortical policies read (SB3's and the batched PPO's).
OBS_KEYS = ("cortical", "fovea", "eyes")


def make_env(task: str = "fixate", **overrides: Any):
    """A ``BinocularSaccadeEnv`` for ``task`` with :data:`DEFAULT_ENV_KWARGS` (cell actions unless
    ``action_mode="vector"``: the continuous saccade of the SB3 agents)."""
    import envs

    kwargs = {**DEFAULT_ENV_KWARGS, **overrides}
    if kwargs["action_mode"] not in ("cell", "vector") or kwargs["cortex"] != "eyes" or kwargs["grayscale"]:
        raise ValueError(
            "the agents need action_mode 'cell' (or 'vector' for the SB3 agents), cortex='eyes', grayscale=False"
        )
    kwargs["remap_models"] = tuple(kwargs["remap_models"])
    return envs.BinocularSaccadeEnv(task=task, **kwargs)


def episode_seeds(seed: int, n: int, stream: int = EVAL_STREAM, start: int = 0) -> np.ndarray:
    """``n`` env-reset seeds for episodes ``start .. start+n-1`` of ``stream`` under ``seed``
    (streams keep training and evaluation episodes apart)."""
    if n < 0 or start < 0:
        raise ValueError(f"need n >= 0 and start >= 0; got n={n}, start={start}")
    return np.array(
        [
            np.random.SeedSequence([int(seed), stream, i]).generate_state(1)[0] & 0x7FFFFFFF
            for i in range(start, start + n)
        ],
        dtype=np.int64,
    )


def run_episode(env, policy: Policy, seed: int, rng: np.random.Generator) -> tuple[float, int, bool]:
    """One episode from ``env.reset(seed=seed)``: (return, saccades, success)."""
    obs, _ = env.reset(seed=int(seed))
    total, n, done, success = 0.0, 0, False, False
    while not done:
        obs, r, term, trunc, info = env.step(policy.act(obs, rng))
        total += r
        n += 1
        success = bool(info["success"])
        done = term or trunc
    return total, n, success


@dataclass
class Evaluation:
    """Mean results of a set of episodes; ``mean_reward`` is the mean episode return."""

    success_rate: float
    mean_reward: float
    mean_saccades: float
    episodes: int

    def as_dict(self) -> dict[str, float | int]:
        return {
            "success_rate": self.success_rate,
            "mean_reward": self.mean_reward,
            "mean_saccades": self.mean_saccades,
            "episodes": self.episodes,
        }


def evaluate(env, policy: Policy, seeds: np.ndarray, rng_seed: int = 0, progress: bool = False) -> Evaluation:
    """Run ``policy`` for one episode per reset seed; deterministic for fixed seeds. ``progress``:
    a progress bar on stderr."""
    if len(seeds) == 0:
        raise ValueError("need at least one episode")
    rng = np.random.default_rng([int(rng_seed), 12345])
    it = seeds
    if progress:
        from tqdm import tqdm

        it = tqdm(seeds, unit="episode", desc="evaluating")
    res = np.array([run_episode(env, policy, s, rng) for s in it], dtype=np.float64)
    return Evaluation(
        success_rate=float(res[:, 2].mean()),
        mean_reward=float(res[:, 0].mean()),
        mean_saccades=float(res[:, 1].mean()),
        episodes=len(seeds),
    )
