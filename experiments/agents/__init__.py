"""Saccade agents over the superior-colliculus cell map and the cortical map.

- ``policies``: :class:`RandomPolicy`, :class:`BrightestCellPolicy` (heuristic),
  :class:`LinearCellPolicy` (softmax over cells, logits w . phi(obs, cell)), :func:`load_policy`.
- ``rollout``: :func:`make_env`, :func:`evaluate`, :func:`episode_seeds`.
- ``cem``: :func:`train_cem` (noisy cross-entropy method) with :class:`CEMConfig`.
- ``curve``: :func:`plot_learning_curve`, :func:`plot_training_log`, :func:`plot_runs`.
- ``stats``: :func:`iqm`, :func:`bootstrap_ci`, :func:`summarize_runs` (Agarwal et al. 2021).
- ``saved``: agents on disk as data, never pickle: :func:`write_unit` / :func:`read_unit` (arrays and
  their JSON in one ``.npz``, written atomically); ``runfolder``: :func:`check_settings` (one run's
  settings per training folder, ``train.json``; another run's folder refused).
- ``extractors`` (torch): :class:`WrapConv2d`, :class:`CorticalEncoder`, :class:`SoftArgmaxSaccade`;
  ``augment`` (torch): :func:`random_shifts` of the cortical map (DrQ; circular in angle).
- ``sb3`` (the ``rl`` extra): PPO / SAC policies over the cortical map and :func:`train_sb3`;
  ``hyperparams``: :func:`load_hyperparams` (``experiments/hyperparams/*.yml``); ``baselines``:
  :func:`~experiments.agents.baselines.run_baselines` (agents x seeds on one task, held-out IQM table
  and curves; ``python -m experiments baselines``).
- ``batched_ppo`` (the ``gpu`` extra): PPO on the batched env with the cortical cell policy
  (:func:`~experiments.agents.batched_ppo.train_batched`; ``train --engine batched``, options checked in
  ``batched_cli``), saved as ``ppo.npz`` + ``ppo.json`` and run on the single env by ``evaluate``.

The torch and Stable-Baselines3 modules are imported on use (``from experiments.agents.sb3 import ...``),
so the numpy agents need neither.
"""

from .cem import CEMConfig, train_cem
from .curve import plot_learning_curve, plot_runs, plot_training_log, read_training_log
from .policies import BrightestCellPolicy, LinearCellPolicy, RandomPolicy, cell_features, feature_names, load_policy
from .rollout import DEFAULT_ENV_KWARGS, Evaluation, episode_seeds, evaluate, make_env
from .runfolder import check_settings
from .saved import read_unit, write_unit
from .stats import bootstrap_ci, iqm, summarize_runs

__all__ = [
    "BrightestCellPolicy",
    "CEMConfig",
    "DEFAULT_ENV_KWARGS",
    "Evaluation",
    "LinearCellPolicy",
    "RandomPolicy",
    "bootstrap_ci",
    "cell_features",
    "check_settings",
    "episode_seeds",
    "evaluate",
    "feature_names",
    "iqm",
    "load_policy",
    "make_env",
    "plot_learning_curve",
    "plot_runs",
    "plot_training_log",
    "read_training_log",
    "read_unit",
    "summarize_runs",
    "train_cem",
    "write_unit",
]
