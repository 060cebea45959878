"""The RL baselines table and figure: held-out results of several training runs (seeds) per agent,
aggregated as interquartile mean with a percentile-bootstrap 95 % CI (Agarwal et al. 2021)."""

from __future__ import annotations

from pathlib import Path

from ..folders import write_csv
from .curve import plot_runs, read_training_log
from .stats import summarize_runs

__all__ = ["aggregate_runs"]


def aggregate_runs(runs: dict[str, list[str | Path]], held_out: dict[str, list[float]],
                   baselines: dict[str, dict[str, float]], csv_path: str | Path, png_path: str | Path,
                   title: str = "", keys: tuple[str, ...] = ("success_rate", "mean_return")) -> list[dict]:
    """``runs``: agent -> its run folders (each with ``training_log.csv``); ``held_out``: agent -> the
    per-run held-out success rate (e.g. on 100 episodes); ``baselines``: name -> {"success_rate", "mean_return"}.
    Writes one CSV row per agent (IQM, CI, mean, runs of the held-out success rate) and the IQM curves
    of ``keys`` (columns of ``training_log.csv``) over env steps; returns the rows."""
    rows = []
    for name, scores in held_out.items():
        rows.append({"agent": name, **{k: round(v, 4) if isinstance(v, float) else v
                                       for k, v in summarize_runs(scores).items()},
                     "scores": " ".join(f"{s:.2f}" for s in scores)})
    for name, b in baselines.items():
        v = b["success_rate"]
        rows.append({"agent": name, "iqm": v, "ci_low": v, "ci_high": v, "mean": v, "runs": 1, "scores": f"{v:.2f}"})
    write_csv(csv_path, list(rows[0]), rows)
    curves = {name: [read_training_log(Path(d) / "training_log.csv") for d in dirs] for name, dirs in runs.items()}
    plot_runs(curves, baselines, png_path, keys=keys, title=title)
    return rows
