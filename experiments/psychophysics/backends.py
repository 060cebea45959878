"""Where batches of trials run: ``local`` (this process, or spawned worker processes) or ``ray``
(actors on a local Ray instance, or on a cluster at ``ray_address``): the ``--backend`` and
``--workers`` of the heavy commands (``run``, ``phenomena``, ``fit``, ``compare``, ``recovery``).

:func:`ray_map` is the one Ray path: each actor sets itself up once (``init(*init_args)``) and runs
``work(batch)`` for the batches it is given; results are handed to ``on_result`` as they finish, so
the caller writes them as the local pool's would be. Actors of a local instance watch the driver's
pid and exit within half a second of it (``folders.die_with``). A trial's result depends only on the
trial and the configuration, so both backends give the same numbers.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from typing import Any

__all__ = ["BACKENDS", "check_backend", "ray_map"]

BACKENDS = ("local", "ray")
RAY_MISSING = 'the ray backend needs Ray: pip install -e ".[ray]" (or pip install ray)'


def check_backend(backend: str, ray_address: str | None = None) -> None:
    """``ValueError`` for an unknown backend, or an address without the ray backend."""
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {', '.join(BACKENDS)}; got {backend!r}")
    if ray_address is not None and backend != "ray":
        raise ValueError("ray_address is only for the ray backend (the local backend starts no cluster)")


def ray_map(
    init: Callable[..., None],
    init_args: tuple,
    work: Callable[[Any], Any],
    batches: Sequence,
    on_result: Callable[[int, Any], None],
    *,
    workers: int,
    address: str | None = None,
) -> None:
    """Run ``work(batch)`` for every batch on at most ``workers`` Ray actors (batch k on actor
    k mod n), calling ``on_result(k, result)`` as each finishes. Starts (and afterwards stops) a
    local Ray instance unless one is running or ``address`` names a cluster."""
    try:
        import ray
    except ImportError:
        raise RuntimeError(RAY_MISSING) from None
    started = False
    if not ray.is_initialized():
        if address:
            ray.init(address=address, include_dashboard=False, log_to_driver=False)
        else:
            ray.init(num_cpus=max(1, workers), include_dashboard=False, log_to_driver=False)
        started = True
    try:

        @ray.remote(num_cpus=1)
        class ExperimentWorker:  # its processes are titled ray::ExperimentWorker
            def __init__(self, driver_pid):
                if driver_pid is not None:  # a local instance: exit with the driver, even after its kill -9
                    from ..folders import die_with

                    die_with(driver_pid)
                init(*init_args)

            def run(self, batch):
                return work(batch)

        n = max(1, min(workers, len(batches)))
        actors = [ExperimentWorker.remote(None if address else os.getpid()) for _ in range(n)]  # type: ignore[attr-defined]
        refs = {actors[k % n].run.remote(b): k for k, b in enumerate(batches)}
        pending = list(refs)
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            for r in ready:
                on_result(refs[r], ray.get(r))
        for a in actors:
            ray.kill(a)
    finally:
        if started:
            ray.shutdown()
