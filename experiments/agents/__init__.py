"""Saccade agents over the superior-colliculus cell map, without deep-learning dependencies.

- ``policies``: :class:`RandomPolicy`, :class:`BrightestCellPolicy` (heuristic),
  :class:`LinearCellPolicy` (softmax over cells, logits w . phi(obs, cell)), :func:`load_policy`.
- ``rollout``: :func:`make_env`, :func:`evaluate`, :func:`episode_seeds`.
- ``cem``: :func:`train_cem` (noisy cross-entropy method) with :class:`CEMConfig`.
- ``curve``: :func:`plot_learning_curve`.

The Stable-Baselines3 recipe is ``experiments.sb3_recipe`` (optional ``rl`` extra).
"""

from .cem import CEMConfig, train_cem
from .curve import plot_learning_curve
from .policies import (BrightestCellPolicy, LinearCellPolicy, RandomPolicy, cell_features,
                       feature_names, load_policy)
from .rollout import DEFAULT_ENV_KWARGS, Evaluation, episode_seeds, evaluate, make_env

__all__ = ["BrightestCellPolicy", "CEMConfig", "DEFAULT_ENV_KWARGS", "Evaluation", "LinearCellPolicy",
           "RandomPolicy", "cell_features", "episode_seeds", "evaluate", "feature_names", "load_policy",
           "make_env", "plot_learning_curve", "train_cem"]
