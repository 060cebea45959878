"""The batched planner's general and fast kernel paths timed side by side, bit for bit
(``benchmarks/planner.py``; the paths themselves: ``models/_plan_kernels.py``)."""

from __future__ import annotations

import time

import numpy as np

from . import _plan_kernels as K
from .saccade_plans import _NO_CDF, KNOT_MS, SaccadePlans, _cdf_grid

__all__ = ["time_kernel_paths"]


def time_kernel_paths(plans: SaccadePlans, now: np.ndarray, spent: dict, repeats: int) -> dict[str, bool]:
    """Times the command tables and the eye-position signal of ``plans`` (the signal at times ``now``,
    (n, 1)) by the general kernels (the tables as ``angles`` at an (n, T) array of times, the signal's
    Gaussian CDF at every knot) and by the fast ones (``command_rows``, the tabulated CDF), appending
    seconds per call to ``spent["tables, general"]`` etc. (``repeats`` calls each, after one first
    touch); returns, per part, whether every bit agrees. For ``benchmarks/planner.py``."""

    n = plans.n
    count = plans.end_ms - plans.onset_ms + 1
    T = int(count.max())
    ex = (*plans.executed_profiles.args(), *plans._args("executed"))
    eps = plans.eye_position
    t = plans._rel(now) - eps.delay_ms
    knots = np.ceil((plans.settle_ms + KNOT_MS) / KNOT_MS).astype(np.int64)
    sig = (*plans.profiles.args(), *plans._args("intended"), KNOT_MS, knots, t, eps.sigma_ms)
    out = {k: np.empty((n, T, 2, 3)) for k in ("g", "f")}
    smooth = {k: np.empty((n, 1, 4)) for k in ("g", "f")}

    def tables_general():
        times = np.minimum(np.arange(T, dtype=float)[None, :], (count - 1)[:, None].astype(float))
        K.angles(*ex, times, out["g"])

    def signal_fast():
        K.signals(*sig, *_cdf_grid(t, knots, eps.sigma_ms), smooth["f"])

    runs = {
        "tables, general": tables_general,
        "tables, fast": lambda: K.command_rows(*ex, count, np.arange(n), out["f"]),
        "signal, general": lambda: K.signals(*sig, _NO_CDF, 0.0, smooth["g"]),
        "signal, fast": signal_fast,
    }
    for f in runs.values():
        f()  # the first touch of the arrays' pages
    for _ in range(repeats):
        for name, f in runs.items():
            t0 = time.perf_counter()
            f()
            spent.setdefault(name, []).append(time.perf_counter() - t0)
    return {
        "tables": np.array_equal(out["g"].view(np.uint64), out["f"].view(np.uint64)),
        "signal": np.array_equal(smooth["g"].view(np.uint64), smooth["f"].view(np.uint64)),
    }
