"""Learning-curve figures: a CEM run, an SB3 run (its training_log.csv), and IQM curves over seeds."""

from __future__ import annotations

from pathlib import Path

__all__ = ["plot_learning_curve", "plot_runs", "plot_training_log", "read_training_log"]


def _save(fig, path: str | Path, title: str, fontsize: float | None = None) -> Path:
    """Give ``fig`` its title, write it to ``path`` (110 dpi) and close it."""
    from ..folders import save_figure

    if title:
        fig.suptitle(title, fontsize=fontsize)
    return save_figure(fig, path, dpi=110)


def plot_learning_curve(curve: list[dict], baselines: dict[str, dict], path: str | Path, title: str = "") -> Path:
    """Success rate and mean episode return of the mean policy vs CEM iteration, with the random
    and brightest-cell heuristic baselines (same validation episodes) as horizontal lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if not curve:
        raise ValueError("empty learning curve")
    it = [r["iteration"] for r in curve]
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.4), constrained_layout=True)
    styles = {"random": ("tab:gray", ":"), "heuristic": ("tab:orange", "--")}
    for ax, key, label in ((axes[0], "success_rate", "success rate"), (axes[1], "mean_reward", "mean episode return")):
        ax.plot(it, [r[key] for r in curve], "o-", color="tab:blue", label="CEM linear cell policy")
        for name, res in baselines.items():
            color, ls = styles.get(name, ("k", "-."))
            ax.axhline(res[key], color=color, ls=ls, label=f"{name} ({res[key]:.2f})")
        ax.set_xlabel("CEM iteration")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].set_ylim(-0.03, 1.03)
    axes[0].legend(loc="lower right", fontsize=8)
    return _save(fig, path, title)


def read_training_log(path: str | Path) -> dict[str, list[float]]:
    """The columns of an SB3 agent's ``training_log.csv`` as float lists (empty cells: NaN)."""
    import csv

    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
        if not rows:
            raise ValueError("no rows")
        return {k: [float(r[k]) if r[k] not in ("", None) else float("nan") for r in rows] for k in rows[0]}
    except (UnicodeDecodeError, csv.Error, ValueError, TypeError) as err:
        raise ValueError(
            f"{path} is not a training log ({type(err).__name__}: {str(err)[:120]}); train that run again"
        ) from None


def plot_training_log(csv_path: str | Path, path: str | Path, title: str = "") -> Path:
    """Validation success rate and mean return vs env steps of one SB3 run (its ``training_log.csv``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    log = read_training_log(csv_path)
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.4), constrained_layout=True)
    for ax, key, label in ((axes[0], "success_rate", "success rate"), (axes[1], "mean_return", "mean episode return")):
        ax.plot(log["env_steps"], log[key], "o-", color="tab:blue")
        ax.set_xlabel("env steps (saccades)")
        ax.set_ylabel(f"validation {label}")
        ax.grid(alpha=0.3)
    axes[0].set_ylim(-0.03, 1.03)
    return _save(fig, path, title)


def plot_runs(
    curves: dict[str, list[dict[str, list[float]]]],
    baselines: dict[str, dict[str, float]],
    path: str | Path,
    keys: tuple[str, ...] = ("success_rate", "mean_return"),
    title: str = "",
    seed: int = 0,
) -> Path:
    """One panel per ``keys`` entry: the IQM over runs (seeds) vs env steps with a percentile-bootstrap
    95 % band, per agent (``curves``: agent -> one :func:`read_training_log` dict per run, evaluated at the
    same steps), and ``baselines`` (name -> {key: value}) as horizontal lines (Agarwal et al. 2021)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from .stats import bootstrap_ci, iqm

    fig, axes = plt.subplots(1, len(keys), figsize=(5.2 * len(keys), 3.7), constrained_layout=True, squeeze=False)
    for ax, key in zip(axes[0], keys):
        for name, runs in curves.items():
            n = min(len(r["env_steps"]) for r in runs)
            steps = np.asarray(runs[0]["env_steps"][:n])
            vals = np.array([r[key][:n] for r in runs])  # (runs, points)
            ok = np.all(np.isfinite(vals), axis=0)  # e.g. no training episode had ended at step 0
            steps, vals = steps[ok], vals[:, ok]
            mid = [iqm(vals[:, j]) for j in range(vals.shape[1])]
            band = np.array([bootstrap_ci(vals[:, j], iqm, reps=1000, seed=seed) for j in range(vals.shape[1])])
            (line,) = ax.plot(steps, mid, "o-", label=f"{name} (IQM, {len(runs)} seed{'s' * (len(runs) > 1)})")
            ax.fill_between(steps, band[:, 0], band[:, 1], color=line.get_color(), alpha=0.2)
        styles = ["--", ":", "-."]
        for i, (name, v) in enumerate(baselines.items()):
            if key in v and np.isfinite(v[key]):
                ax.axhline(v[key], color=f"C{i + 5}", ls=styles[i % 3], lw=1.2, label=f"{name} ({v[key]:.2f})")
        ax.set_xlabel("env steps (saccades)")
        ax.set_ylabel(
            {
                "success_rate": "validation success rate (deterministic)",
                "mean_return": "validation mean episode return",
                "train_success_rate": "training-episode success rate (sampled actions)",
                "train_return": "training-episode return (task reward)",
            }.get(key, key.replace("_", " "))
        )
        if "success" in key:
            ax.set_ylim(-0.03, 1.03)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    return _save(fig, path, title, fontsize=9)
