"""Aggregate scores over training runs: interquartile mean and a percentile-bootstrap 95 % CI.

Agarwal, Schwarzer, Castro, Courville & Bellemare 2021, "Deep reinforcement learning at the edge of
the statistical precipice" (NeurIPS): report the interquartile mean (IQM: the mean of the middle
50 % of the run scores, ``scipy.stats.trim_mean(x, 0.25)``, as ``rliable.metrics.aggregate_iqm``)
with a percentile bootstrap confidence interval over runs (as ``rliable.library.get_interval_estimates``
for one task: runs resampled with replacement). With fewer than 4 runs the IQM trims nothing and
equals the mean; the interval is then wide, as it should be.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["bootstrap_ci", "iqm", "summarize_runs"]


def _scores(scores) -> np.ndarray:
    x = np.asarray(scores, dtype=np.float64).ravel()
    if x.size == 0 or not np.all(np.isfinite(x)):
        raise ValueError(f"scores must be a non-empty array of finite numbers; got {np.asarray(scores)!r:.80}")
    return x


def iqm(scores) -> float:
    """Interquartile mean: the mean after discarding the lowest and highest 25 % of the scores."""
    from scipy import stats  # on use: `train --help` answers without importing scipy

    return float(stats.trim_mean(_scores(scores), 0.25))


def bootstrap_ci(
    scores, statistic: Callable[[np.ndarray], float] = iqm, reps: int = 2000, confidence: float = 0.95, seed: int = 0
) -> tuple[float, float]:
    """Percentile-bootstrap interval of ``statistic`` over runs: ``reps`` resamples of the runs with
    replacement; the (1-confidence)/2 and (1+confidence)/2 quantiles of the statistic."""
    x = _scores(scores)
    if not (isinstance(reps, (int, np.integer)) and reps >= 1):
        raise ValueError(f"reps must be a positive integer; got {reps!r}")
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must be in (0, 1); got {confidence!r}")
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, x.size, size=(int(reps), x.size))
    if statistic is iqm:  # all resamples at once: row by row, the same partition and sum as iqm's (same bits)
        from scipy import stats

        boot = stats.trim_mean(x[idx], 0.25, axis=1)
    else:
        boot = np.array([statistic(x[i]) for i in idx])
    a = (1 - confidence) / 2
    lo, hi = np.quantile(boot, [a, 1 - a])
    return float(lo), float(hi)


def summarize_runs(scores, reps: int = 2000, seed: int = 0) -> dict[str, float | int]:
    """``{"iqm", "ci_low", "ci_high", "mean", "runs"}`` of per-run scores."""
    x = _scores(scores)
    lo, hi = bootstrap_ci(x, iqm, reps=reps, seed=seed)
    return {"iqm": iqm(x), "ci_low": lo, "ci_high": hi, "mean": float(x.mean()), "runs": int(x.size)}
