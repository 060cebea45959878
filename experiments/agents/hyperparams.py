"""Hyper-parameter files of the SB3 agents, in the style of RL Baselines3 Zoo (Raffin 2020): one YAML
file per algorithm in ``experiments/hyperparams/`` (``ppo.yml``, ``sac.yml``), one entry per task."""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["HYPERPARAMS_DIR", "load_hyperparams"]

#: The folder of the algorithms' YAML files (package data of ``experiments``).
HYPERPARAMS_DIR = Path(__file__).resolve().parent.parent / "hyperparams"


def load_hyperparams(algo: str, task: str, path: str | Path | None = None) -> dict[str, Any]:
    """The entry ``task`` of ``<algo>.yml`` (or of the YAML file ``path``) as a dict."""
    import yaml

    f = Path(path) if path is not None else HYPERPARAMS_DIR / f"{algo}.yml"
    if not f.is_file():
        raise FileNotFoundError(f"no hyper-parameter file {f}: algo must be one of ppo, sac (or pass a YAML file)")
    try:
        data = yaml.safe_load(f.read_text())
    except yaml.YAMLError as err:
        raise ValueError(f"{f} is not valid YAML: {err}") from None
    if not isinstance(data, dict) or task not in data or not isinstance(data[task], dict):
        raise ValueError(f"{f} has no entry for task {task!r}; it has: {', '.join(map(str, data or {}))}")
    return dict(data[task])
