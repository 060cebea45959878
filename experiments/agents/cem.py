"""Cross-entropy-method training of :class:`LinearCellPolicy` (Rubinstein 1999; Szita & Lorincz
2006 "Learning Tetris using the noisy cross-entropy method": a Gaussian over the weights,
refitted to the elite candidates each iteration, with decaying extra noise).

Candidates of an iteration are scored on the same training episodes (common random numbers);
after every iteration the mean policy is evaluated on a fixed validation set, a row is appended
to ``training_log.csv`` and ``checkpoint.npz`` is replaced (the Gaussian and the generator's state),
so an interrupted run loses at most one iteration and resumes to the same weights
(:mod:`experiments.agents.runfolder`).
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from ..folders import append_csv_row, write_csv, write_json
from .policies import BrightestCellPolicy, LinearCellPolicy, RandomPolicy, feature_names, load_policy
from .rollout import DEFAULT_ENV_KWARGS, TRAIN_STREAM, VALIDATION_STREAM, episode_seeds, evaluate, make_env
from .runfolder import CHECKPOINT, SETTINGS, check_settings
from .saved import read_unit, write_unit

__all__ = ["CEMConfig", "LOG_COLUMNS", "VALIDATION_STREAM", "train_cem"]

LOG_COLUMNS = (
    "iteration",
    "elite_return",
    "population_return",
    "success_rate",
    "mean_reward",
    "mean_saccades",
    "sigma",
    "elapsed_s",
    "env_steps",
)


@dataclass
class CEMConfig:
    """Hyper-parameters; :meth:`quick` is a run of well under a minute on 2 cores."""

    iterations: int = 20
    population: int = 16
    episodes: int = 8  # training episodes per candidate
    elite_frac: float = 0.25
    init_std: float = 2.0  # initial std of the colour/contrast weights
    ring_std: float = 0.3  # initial std of the per-ring (eccentricity) biases
    extra_std: float = 1.0  # added noise, decaying linearly to 0 at half the iterations
    eval_episodes: int = 40  # validation episodes per iteration (and for the baselines)

    #: the fields that count something (whole numbers >= 1)
    COUNTS: ClassVar[tuple[str, ...]] = ("iterations", "population", "episodes", "eval_episodes")

    @classmethod
    def quick(cls) -> CEMConfig:
        return cls(iterations=5, population=12, episodes=4, eval_episodes=16)

    @classmethod
    def from_mapping(cls, entry: dict, source: str = "CEM hyper-parameters") -> CEMConfig:
        """A validated config from a mapping of field names (a YAML entry, as ``baselines
        --cem-hyperparams`` reads); the fields it leaves out keep their defaults."""
        known = {f.name for f in fields(cls)}
        bad = sorted(map(str, set(entry) - known))
        if bad:
            raise ValueError(
                f"{source}: unknown CEM hyper-parameter(s) {', '.join(bad)}; known: {', '.join(sorted(known))}"
            )
        whole = cls.COUNTS
        values = asdict(cls(**entry))
        for k, v in values.items():
            number = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
            if not number or (k in whole and v != int(v)):
                raise ValueError(f"{source}: {k} must be a {'whole' if k in whole else 'finite'} number; got {v!r}")
        typed: dict[str, Any] = {k: int(v) if k in whole else float(v) for k, v in values.items()}
        config = cls(**typed)
        try:
            config.validate()
        except ValueError as err:
            raise ValueError(f"{source}: {err}") from None
        return config

    def validate(self) -> None:
        for name in self.COUNTS:
            if int(getattr(self, name)) < 1:
                raise ValueError(f"{name} must be >= 1; got {getattr(self, name)!r}")
        if not 0 < self.elite_frac <= 1 or round(self.elite_frac * self.population) < 1:
            raise ValueError(f"elite_frac must be in (0, 1] and leave >= 1 elite; got {self.elite_frac!r}")
        if not (self.init_std > 0 and self.ring_std > 0 and self.extra_std >= 0):
            raise ValueError("init_std and ring_std must be > 0 and extra_std >= 0")


def _finished(out: Path, settings: dict) -> tuple[LinearCellPolicy, dict] | None:
    """The policy and summary of a finished run with ``settings`` in ``out``, or None."""
    if not (out / "policy.json").exists():
        return None
    policy = load_policy(out)
    if policy.metadata.get("settings") != settings:
        raise ValueError(f"{out / 'policy.json'} describes another run than {SETTINGS}; use another --out")
    return policy, policy.metadata


def train_cem(
    out: str | Path,
    task: str = "fixate",
    config: CEMConfig | None = None,
    seed: int = 0,
    env_kwargs: dict | None = None,
    progress: bool = True,
    log: Callable[[str], None] | None = None,
) -> tuple[LinearCellPolicy, dict]:
    """Train a linear cell policy on ``task``, or resume the run in ``out``; writes ``train.json``
    (the settings), ``baselines.json``, ``training_log.csv`` (a row per iteration), ``checkpoint.npz``
    after every iteration (the Gaussian, the generator's state and the curve: one file, replaced
    atomically) and, last, ``policy.npz`` + ``policy.json``. A resumed run ends with the same weights
    as one never stopped. ``log`` (e.g. ``baselines``' stderr) gets a line per iteration, as the SB3 runs'
    evaluations do. Returns the policy and a summary dict (curve, baselines)."""
    from tqdm import tqdm

    cfg = config or CEMConfig()
    cfg.validate()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    env_kwargs = {**DEFAULT_ENV_KWARGS, **(env_kwargs or {})}
    settings = json.loads(
        json.dumps(
            {
                "format": "cem-npz-1",
                "trainer": "cem",
                "task": task,
                "seed": int(seed),
                "config": asdict(cfg),
                "env_kwargs": env_kwargs,
            }
        )
    )
    check_settings(out, settings)
    done = _finished(out, settings)
    if done is not None:
        return done
    log_path, ck = out / "training_log.csv", out / CHECKPOINT
    env = make_env(task, **env_kwargs)
    try:
        M, N = env.vision.grid.M, env.vision.grid.N
        dim = len(feature_names(M))
        rng = np.random.default_rng([int(seed), 777])
        val_seeds = episode_seeds(seed, cfg.eval_episodes, VALIDATION_STREAM)
        sigma0 = np.r_[np.full(dim - M, cfg.init_std), np.full(M, cfg.ring_std)]
        n_elite = max(1, round(cfg.elite_frac * cfg.population))
        start, before_s, steps = 0, 0.0, 0  # steps: training env steps (saccades) so far, validation excluded
        if ck.exists():
            arrays, state = read_unit(ck, hint=f"delete {ck.name} to train this run again")
            try:
                if state["settings"] != settings:
                    raise ValueError("other settings")
                mu, sigma = np.asarray(arrays["mu"], np.float64), np.asarray(arrays["sigma"], np.float64)
                if mu.shape != (dim,) or sigma.shape != (dim,):
                    raise ValueError(f"weights of shape {mu.shape}, not ({dim},)")
                rng.bit_generator.state = state["rng"]
                start, before_s, steps = int(state["iteration"]), float(state["elapsed_s"]), int(state["env_steps"])
                baselines, curve = dict(state["baselines"]), list(state["curve"])
            except (KeyError, TypeError, ValueError) as err:
                raise ValueError(f"{ck} does not fit this run ({err}); delete it to train this run again") from None
            write_csv(log_path, list(LOG_COLUMNS), curve)
        else:
            log_path.unlink(missing_ok=True)
            baselines = {
                p.name: evaluate(env, p, val_seeds, rng_seed=seed).as_dict()
                for p in (RandomPolicy(M * N), BrightestCellPolicy())
            }
            mu, sigma, curve = np.zeros(dim), sigma0.copy(), []
        write_json(out / "baselines.json", baselines)
        meta = {
            "task": task,
            "env_kwargs": env_kwargs,
            "seed": int(seed),
            "trainer": "cem",
            "config": asdict(cfg),
            "grid": {"M": M, "N": N},
            "baselines": baselines,
            "curve": curve,
            "settings": settings,
        }
        t0 = time.perf_counter()
        policy = LinearCellPolicy(mu.copy(), metadata=meta)
        bar = tqdm(
            range(start, cfg.iterations),
            desc=f"CEM {task}",
            unit="it",
            disable=not progress,
            initial=start,
            total=cfg.iterations,
        )
        for it in bar:
            seeds = episode_seeds(seed, cfg.episodes, TRAIN_STREAM, start=it * cfg.episodes)
            cands = mu + sigma * rng.standard_normal((cfg.population, dim))
            evs = [evaluate(env, LinearCellPolicy(w), seeds, rng_seed=seed) for w in cands]
            scores = np.array([e.mean_reward for e in evs])
            steps += sum(round(e.mean_saccades * e.episodes) for e in evs)
            elite = cands[np.argsort(-scores, kind="stable")[:n_elite]]
            extra = cfg.extra_std * max(0.0, 1.0 - it / max(1.0, cfg.iterations / 2))
            extra = extra * sigma0 / sigma0.max()  # keep the ring/colour scale ratio
            mu, sigma = elite.mean(axis=0), elite.std(axis=0) + extra
            policy = LinearCellPolicy(mu.copy(), metadata=meta)
            ev = evaluate(env, policy, val_seeds, rng_seed=seed)
            row = {
                "iteration": it + 1,
                "elite_return": float(np.sort(scores)[-n_elite:].mean()),
                "population_return": float(scores.mean()),
                **ev.as_dict(),
                "sigma": float(sigma.mean()),
                "elapsed_s": round(before_s + time.perf_counter() - t0, 2),
                "env_steps": steps,
            }
            row.pop("episodes")
            append_csv_row(log_path, LOG_COLUMNS, row)
            curve.append(row)
            write_unit(
                ck,
                {"mu": mu, "sigma": sigma},
                {
                    "settings": settings,
                    "rng": rng.bit_generator.state,
                    "iteration": it + 1,
                    "elapsed_s": before_s + time.perf_counter() - t0,
                    "env_steps": steps,
                    "baselines": baselines,
                    "curve": curve,
                },
            )
            bar.set_postfix(success=f"{ev.success_rate:.2f}", reward=f"{ev.mean_reward:.3f}")
            if log is not None:
                log(
                    f"cem {task}: iteration {it + 1}/{cfg.iterations}, {steps} env steps, {row['elapsed_s']:.0f} s: "
                    f"validation success {ev.success_rate:.2f}, return {ev.mean_reward:+.3f}"
                )
        policy.save(out)
        ck.unlink(missing_ok=True)
        return policy, meta
    finally:
        env.close()
