"""The expensive, parameter-free stage of a fit: observing every trial the data asks for, once.

A model fit changes only read-out parameters (``psychophysics.READOUT_PARAMETERS``), so each trial
is rendered and seen by the retina once (``TrialRunner.observe``) and re-read for every parameter
set (``TrialRunner.readout``): the real pipeline, not a surrogate. Observations are cached on
disk (``DIR/observations/*.npz``: numeric arrays only, read without pickle, keyed by a hash of the
trials and the observing configuration and verified by a checksum; ``modelfit.cache``), so a fit
that is interrupted resumes without rendering again. A cache that fails its checks is rebuilt,
with a message on stderr. A fit always reads its observations back from the cache it wrote, so an
uninterrupted fit and a resumed one start from the same bytes.

Worker processes exit with their parent, even after ``kill -9`` (``folders.die_with_parent``), and
use one BLAS/OpenMP thread each. Ray actors of a local instance watch the driver's pid and exit
within half a second of it (``folders.die_with``); Ray's own processes die with the driver by Ray's
kernel fate-sharing (its agents within about a minute).

Backends: ``local`` (in-process for ``workers=1``, else spawned processes) and ``ray`` (actors on
a local Ray instance, or on a cluster with ``ray_address``). Both give identical observations: a
trial's rendering depends only on the trial and the configuration.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

from ..cli.progress import Progress, stage
from ..psychophysics.backends import BACKENDS

__all__ = ["BACKENDS", "observe_trials", "observation_key"]
_RUNNER = None


def observation_key(trials, config) -> str:
    """12 hex digits identifying the trials and every field of the observing configuration that the
    observation depends on (all but ``psychophysics.trial.READOUT_ONLY``)."""
    import dataclasses

    from ..psychophysics.trial import READOUT_ONLY

    cfg = {f.name: repr(getattr(config, f.name)) for f in dataclasses.fields(config) if f.name not in READOUT_ONLY}
    text = json.dumps({"trials": [repr(t) for t in trials], "config": cfg}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def _strip(obs):
    obs.frame = obs.reference = None  # the frames are for recordings; a fit needs the maps
    return obs


def _init(config, parent_pid: int | None = None) -> None:
    global _RUNNER
    import signal

    from threadpoolctl import threadpool_limits

    from ..psychophysics import TrialRunner

    if parent_pid is not None:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the process group: the parent stops us
        from ..folders import die_with_parent

        die_with_parent(parent_pid)
    _RUNNER = TrialRunner(config)
    threadpool_limits(1)  # after TrialRunner: every BLAS/OpenMP library it loads is limited


def _observe_batch(trials) -> list:
    assert _RUNNER is not None, "the worker's runner is made by _init before any batch"
    return [_strip(_RUNNER.observe(t)) for t in trials]


def _batches(items: list, n: int) -> list[list]:
    n = max(1, min(n, len(items)))
    return [items[i::n] for i in range(n)]


def _local(trials, config, workers: int, progress) -> list:
    if workers <= 1:
        _init(config)
        out = []
        for i in range(0, len(trials), 8):
            out += _observe_batch(trials[i : i + 8])
            progress(len(trials[i : i + 8]))
        return out
    import multiprocessing as mp

    from ..psychophysics.runner import _stop_pool

    out = [None] * len(trials)
    size = max(1, min(8, -(-len(trials) // (2 * workers))))  # every worker gets work
    chunks = [list(range(i, min(i + size, len(trials)))) for i in range(0, len(trials), size)]
    pool = ProcessPoolExecutor(
        workers, mp_context=mp.get_context("spawn"), initializer=_init, initargs=(config, os.getpid())
    )
    try:
        futures = {pool.submit(_observe_batch, [trials[i] for i in idx]): idx for idx in chunks}
        for f in as_completed(futures):
            for i, o in zip(futures[f], f.result()):
                out[i] = o
            progress(len(futures[f]))
    except BaseException:
        _stop_pool(pool)
        raise
    pool.shutdown(wait=True)
    return out


def _ray(trials, config, workers: int, address: str | None, progress) -> list:
    from ..psychophysics.backends import ray_map

    n_actors = max(1, min(workers, len(trials)))
    batches = _batches(list(range(len(trials))), n_actors)
    small = [idx[j : j + 8] for idx in batches for j in range(0, len(idx), 8)]
    out = [None] * len(trials)

    def done(k: int, obs: list) -> None:
        for i, o in zip(small[k], obs):
            out[i] = o
        progress(len(small[k]))

    ray_map(
        _init,
        (config,),
        _observe_batch,
        [[trials[i] for i in idx] for idx in small],
        done,
        workers=n_actors,
        address=address,
    )
    return out


def observe_trials(
    trials: list,
    config,
    cache_dir: Path | None = None,
    *,
    backend: str = "local",
    workers: int = 1,
    ray_address: str | None = None,
    progress: bool = False,
    runner=None,
) -> list:
    """Observations of ``trials`` under ``config``.

    With ``cache_dir``, they are read from (or computed and written to) its verified ``.npz``
    cache (``modelfit.cache``) and always returned as read back from it; ``runner`` is a
    ``TrialRunner`` of ``config`` to rebuild them against (made here when not given). ``progress``
    shows a progress bar (tqdm, on stderr) while trials are observed."""
    from . import cache

    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {', '.join(BACKENDS)}; got {backend!r}")
    path = key = None
    if cache_dir is not None:
        from ..psychophysics import TrialRunner

        cache_dir = Path(cache_dir)
        cache_dir.mkdir(parents=True, exist_ok=True)
        key = observation_key(trials, config)
        path = cache_dir / f"{config.condition}-{key}.npz"
        runner = runner if runner is not None else TrialRunner(config)
        if path.exists():
            stage(f"reading the observation cache {path}", enabled=progress)
        cached, why = cache.load(path, key, trials, runner)
        if cached is not None:
            return cached
        if path.exists():
            print(f"{path}: {why}; observing its {len(trials)} trials again", file=sys.stderr)
    with Progress(len(trials), unit="trial", desc=f"observing ({config.condition})", enabled=progress) as bar:
        obs = (
            _ray(trials, config, workers, ray_address, bar.update)
            if backend == "ray"
            else _local(trials, config, workers, bar.update)
        )
    if path is None:
        return obs
    assert key is not None, "the cache key is made with the cache path"
    cache.save(path, obs, key)
    back, why = cache.load(path, key, trials, runner)
    if back is None:
        raise RuntimeError(f"{path}: the observations just written do not read back ({why})")
    return back
