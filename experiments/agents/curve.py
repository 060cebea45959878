"""The learning-curve figure of a CEM run."""

from __future__ import annotations

from pathlib import Path

__all__ = ["plot_learning_curve"]


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
    if title:
        fig.suptitle(title)
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
