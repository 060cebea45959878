"""The expensive, parameter-free stage of a fit: observing every trial the data asks for, once.

A model fit changes only read-out parameters (``psychophysics.READOUT_PARAMETERS``), so each trial
is rendered and seen by the retina once (``TrialRunner.observe``) and re-read for every parameter
set (``TrialRunner.readout``): the real pipeline, not a surrogate. Observations are cached on
disk (``DIR/observations/*.pkl``, written atomically, keyed by a hash of the trials and the
observing configuration), so a fit that is interrupted resumes without rendering again.

Backends: ``local`` (in-process for ``workers=1``, else spawned processes) and ``ray`` (actors on
a local Ray instance, or on a cluster with ``ray_address``). Both give identical observations: a
trial's rendering depends only on the trial and the configuration.
"""

from __future__ import annotations

import hashlib
import json
import os
import pickle
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

__all__ = ["BACKENDS", "observe_trials", "observation_key"]

BACKENDS = ("local", "ray")
_RUNNER = None


def observation_key(trials, config) -> str:
    """12 hex digits identifying the trials and every field of the observing configuration."""
    import dataclasses

    cfg = {f.name: repr(getattr(config, f.name)) for f in dataclasses.fields(config)}
    text = json.dumps({"trials": [repr(t) for t in trials], "config": cfg}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def _strip(obs):
    obs.frame = obs.reference = None  # the frames are for recordings; a fit needs the maps
    return obs


def _init(config) -> None:
    global _RUNNER
    from threadpoolctl import threadpool_limits

    from ..psychophysics import TrialRunner

    threadpool_limits(1)
    _RUNNER = TrialRunner(config)


def _observe_batch(trials) -> list:
    return [_strip(_RUNNER.observe(t)) for t in trials]


def _batches(items: list, n: int) -> list[list]:
    n = max(1, min(n, len(items)))
    return [items[i::n] for i in range(n)]


def _local(trials, config, workers: int) -> list:
    if workers <= 1:
        _init(config)
        return _observe_batch(trials)
    import multiprocessing as mp

    order = {id(t): i for i, t in enumerate(trials)}
    out = [None] * len(trials)
    chunks = [trials[i:i + 8] for i in range(0, len(trials), 8)]
    with ProcessPoolExecutor(workers, mp_context=mp.get_context("spawn"), initializer=_init,
                             initargs=(config,)) as pool:
        for chunk, res in zip(chunks, pool.map(_observe_batch, chunks)):
            for t, o in zip(chunk, res):
                out[order[id(t)]] = o
    return out


def _ray(trials, config, workers: int, address: str | None) -> list:
    try:
        import ray
    except ImportError:
        raise RuntimeError("the ray backend needs Ray: pip install -e \".[ray]\" (or pip install ray)") from None
    started = False
    if not ray.is_initialized():
        if address:
            ray.init(address=address, include_dashboard=False, log_to_driver=False)
        else:
            ray.init(num_cpus=max(1, workers), include_dashboard=False, log_to_driver=False)
        started = True
    try:
        @ray.remote(num_cpus=1)
        class Observer:
            def __init__(self, cfg):
                _init(cfg)

            def observe(self, batch):
                return _observe_batch(batch)

        n_actors = max(1, min(workers, len(trials)))
        actors = [Observer.remote(config) for _ in range(n_actors)]
        batches = _batches(list(range(len(trials))), n_actors)
        results = ray.get([a.observe.remote([trials[i] for i in idx]) for a, idx in zip(actors, batches)])
        out = [None] * len(trials)
        for idx, res in zip(batches, results):
            for i, o in zip(idx, res):
                out[i] = o
        for a in actors:
            ray.kill(a)
        return out
    finally:
        if started:
            ray.shutdown()


def observe_trials(trials: list, config, cache_dir: Path | None = None, *, backend: str = "local", workers: int = 1,
                   ray_address: str | None = None) -> list:
    """Observations of ``trials`` under ``config`` (cached in ``cache_dir`` when given)."""
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {', '.join(BACKENDS)}; got {backend!r}")
    path = None
    if cache_dir is not None:
        cache_dir = Path(cache_dir)
        cache_dir.mkdir(parents=True, exist_ok=True)
        path = cache_dir / f"{config.condition}-{observation_key(trials, config)}.pkl"
        if path.exists():
            try:
                with path.open("rb") as fh:
                    cached = pickle.load(fh)
                if len(cached) == len(trials):
                    return cached
            except (OSError, pickle.UnpicklingError, EOFError, AttributeError):
                pass  # a damaged cache is redone
    obs = _ray(trials, config, workers, ray_address) if backend == "ray" else _local(trials, config, workers)
    if path is not None:
        tmp = path.with_name(path.name + f".tmp{os.getpid()}")
        with tmp.open("wb") as fh:
            pickle.dump(obs, fh, protocol=pickle.HIGHEST_PROTOCOL)
        tmp.replace(path)
    return obs
