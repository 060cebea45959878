"""The RL baselines study: several agents x several seeds on one task, evaluated on the same held-out
episodes, aggregated as IQM with a percentile-bootstrap 95 % CI (Agarwal et al. 2021).

``python -m experiments baselines --task fixate --agents ppo sac cem --seeds 0 1 2 --out DIR`` writes:

- ``study.json``: what makes its runs comparable (task, held-out episodes and their seed, budget, image
  size); a folder made with other settings is refused, not mixed. Agents and seeds may be added later
  (the table covers the ones asked for); a run trained with other hyper-parameters is refused.
- ``reference.json``: the brightest-cell heuristic and uniform random cells on the held-out episodes.
- ``<agent>_s<seed>/``: one training run (the folder ``train --algo AGENT`` writes) and, written last,
  its ``heldout.json`` (deterministic and, for PPO/SAC, sampled actions). A run with a valid
  ``heldout.json`` is done and skipped when the command is run again; any other is resumed from its
  checkpoint (:mod:`experiments.agents.runfolder`: the same weights as a run never stopped).
- ``table.csv`` / ``table.md``: per agent, IQM [95 % CI], mean and the per-seed held-out success rates,
  training env steps and wall time; ``curves.png``: PPO's and SAC's curves over env steps (validation
  success and return of the deterministic policy, success of the training episodes with sampled
  actions), IQM over seeds with a bootstrap band, and CEM, the heuristic and random as lines at their
  held-out values.

One writer per folder (a lock); SIGINT/SIGTERM stop it between or inside runs and lose only the run
in progress.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..folders import atomic_write_text, path_lock, write_csv, write_json
from .rollout import EVAL_STREAM, episode_seeds, evaluate, make_env
from .stats import summarize_runs

__all__ = ["AGENTS", "run_baselines"]

AGENTS = ("ppo", "sac", "cem")
STUDY_VERSION = 1


def quick_hyperparams(algo: str, hp: dict[str, Any], eval_episodes: int | None = None) -> dict[str, Any]:
    """``hp`` shrunk for a quick run (256 env steps by default): evaluations every 128 steps on
    ``eval_episodes`` (4) validation episodes, small PPO rollouts, an early SAC start."""
    hp = {**hp, "eval_freq": 128, "eval_episodes": eval_episodes or 4}
    hp.update({"n_steps": 64, "batch_size": 32} if algo == "ppo" else {"learning_starts": 64})
    return hp


def _run_dir(out: Path, agent: str, seed: int) -> Path:
    return out / f"{agent}_s{seed}"


def _read_heldout(path: Path) -> dict | None:
    """A finished run's held-out results, or None when the file is missing or not a complete result."""
    try:
        d = json.loads(path.read_text())
        ok = (
            isinstance(d, dict)
            and isinstance(d.get("deterministic"), dict)
            and all(isinstance(d["deterministic"].get(k), (int, float)) for k in ("success_rate", "mean_reward"))
        )
        return d if ok else None
    except (OSError, ValueError, UnicodeDecodeError):
        return None


def _held_out(env, policy, seeds: np.ndarray, eval_seed: int) -> dict[str, float]:
    return evaluate(env, policy, seeds, rng_seed=eval_seed).as_dict()


def _train_one(
    run: Path,
    agent: str,
    task: str,
    seed: int,
    hp: dict | None,
    timesteps: int | None,
    quick: bool,
    image_size: int,
    log,
) -> dict[str, Any]:
    """Train one run into ``run``, resuming an unfinished one; returns the training metadata (wall
    time, env steps)."""
    if agent == "cem":
        from .cem import CEMConfig, train_cem

        t0 = time.perf_counter()
        _, meta = train_cem(
            run,
            task=task,
            config=CEMConfig(**hp) if hp else CEMConfig.quick() if quick else CEMConfig(),
            seed=seed,
            env_kwargs={"image_size": image_size},
            progress=False,
            log=log,
        )
        last = meta["curve"][-1]
        return {
            "wall_s": round(time.perf_counter() - t0, 1),
            "env_steps": int(last["env_steps"]),
            "iterations": int(last["iteration"]),
        }
    from .sb3 import train_sb3

    assert hp is not None, "the SB3 agents' hyper-parameters are loaded (load_hyperparams)"
    meta = train_sb3(run, agent, task, hp, seed=seed, timesteps=timesteps, log=log)
    return {"wall_s": meta["wall_s"], "env_steps": int(meta["total_timesteps"])}


def _load(run: Path, agent: str, deterministic: bool):
    if agent == "cem":
        from .policies import load_policy

        return load_policy(run)
    from .sb3 import load_agent

    return load_agent(run, deterministic=deterministic)


def run_baselines(
    out: str | Path,
    task: str,
    agents: tuple[str, ...] = AGENTS,
    seeds: tuple[int, ...] = (0, 1, 2),
    episodes: int = 100,
    eval_seed: int = 1,
    timesteps: int | None = None,
    quick: bool = False,
    image_size: int | None = None,
    hyperparams: dict[str, str | Path] | None = None,
    log: Callable[[str], None] = print,
    workers: int = 1,
    backend: str = "local",
    ray_address: str | None = None,
) -> list[dict[str, Any]]:
    """Train and evaluate ``agents`` x ``seeds`` on ``task`` into ``out`` (see the module docstring),
    resuming a folder of the same study; returns the table's rows. ``timesteps`` overrides the PPO/SAC
    budget, ``quick`` shrinks every run (tests), ``image_size`` overrides the env's (96 by default),
    ``hyperparams`` maps ``ppo``/``sac`` to YAML files other than ``experiments/hyperparams/<algo>.yml``,
    and ``cem`` to a YAML file whose ``task`` entry sets ``CEMConfig``'s fields (instead of its defaults,
    or ``CEMConfig.quick()`` with ``quick``). ``workers``, ``backend``, ``ray_address``: the runs to train
    at once, on local processes or Ray actors."""
    from .hyperparams import load_hyperparams

    agents, seeds = tuple(agents), tuple(int(s) for s in seeds)
    bad = [a for a in agents if a not in AGENTS]
    if not agents or bad:
        raise ValueError(f"agents must be some of {', '.join(AGENTS)}; got {', '.join(bad) or 'none'}")
    if len(set(agents)) != len(agents) or len(set(seeds)) != len(seeds) or not seeds:
        raise ValueError("agents and seeds must be non-empty and without repeats")
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1; got {episodes}")
    from ..psychophysics.backends import check_backend

    check_backend(backend, ray_address)
    if quick and timesteps is None:
        timesteps = 256
    hyperparams = dict(hyperparams or {})
    hps: dict[str, dict] = {}
    for a in agents:
        if a == "cem":
            if hyperparams.get("cem") is not None:
                from dataclasses import asdict

                from .cem import CEMConfig

                entry = load_hyperparams("cem", task, hyperparams["cem"])
                hps[a] = asdict(CEMConfig.from_mapping(entry, f"{hyperparams['cem']}, entry {task!r}"))
        else:
            hp = load_hyperparams(a, task, hyperparams.get(a))
            if image_size:
                hp["env_kwargs"] = {**hp.get("env_kwargs", {}), "image_size": image_size}
            hps[a] = quick_hyperparams(a, hp) if quick else hp
    if set(hps) - {"cem"}:
        try:
            import stable_baselines3  # noqa: F401  (imported only to check that it is installed)
        except ImportError:
            raise ValueError("agents ppo/sac need the 'rl' extra: pip install -e '.[rl]' (CPU torch first)") from None
    study = {
        "version": STUDY_VERSION,
        "task": task,
        "episodes": int(episodes),
        "eval_seed": int(eval_seed),
        "timesteps": timesteps,
        "quick": bool(quick),
        "image_size": image_size,
    }
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with path_lock(out / ".lock", f"the baselines folder {out}"):
        _check_study(out / "study.json", study)
        size = int(image_size or 96)
        held_seeds = episode_seeds(eval_seed, episodes, EVAL_STREAM)  # = evaluate --episodes N --seed S
        reference = _reference(out / "reference.json", task, size, held_seeds, eval_seed, log)
        finished: dict[tuple[str, int], dict] = {}
        todo: list[_Job] = []
        for a in agents:
            for s in seeds:
                run = _run_dir(out, a, s)
                done = _read_heldout(run / "heldout.json")
                if done is not None and done.get("hyperparams") != json.loads(json.dumps(hps.get(a))):
                    raise ValueError(
                        f"{run} was trained with other {a} hyper-parameters than the current ones; "
                        "use another --out, or delete that run to train it again"
                    )
                if done is None:
                    todo.append((run, a, task, s, hps.get(a), timesteps, quick, size, held_seeds, eval_seed))
                else:
                    finished[a, s] = done
        for job, done in zip(todo, _train_all(todo, workers, backend, ray_address, log)):
            finished[job[1], job[3]] = done
        results: dict[str, list[dict]] = {a: [] for a in agents}
        for a in agents:
            for s in seeds:
                done = finished[a, s]
                log(
                    f"baselines {task}: {a} seed {s}: held-out success {done['deterministic']['success_rate']:.2f}"
                    + (f" (sampled {done['stochastic']['success_rate']:.2f})" if "stochastic" in done else "")
                )
                results[a].append(done)
        rows = _table(out, task, results, reference)
    return rows


#: one run's arguments to :func:`_train_and_evaluate` (run folder, agent, task, seed, hyper-parameters,
#: timesteps, quick, image size, held-out seeds, evaluation seed)
_Job = tuple[Path, str, str, int, dict | None, int | None, bool, int, np.ndarray, int]


def _train_and_evaluate(
    run: Path,
    a: str,
    task: str,
    s: int,
    hp: dict | None,
    timesteps: int | None,
    quick: bool,
    size: int,
    held_seeds: np.ndarray,
    eval_seed: int,
    log: Callable[[str], None] = print,
) -> dict:
    """One run: train (or resume) it, evaluate it on the held-out episodes, write ``heldout.json``."""
    log(f"baselines {task}: training {a} seed {s} ...")
    trained = _train_one(run, a, task, s, hp, timesteps, quick, size, log)
    done = {"agent": a, "seed": s, **trained, "hyperparams": hp}
    for mode in (True, False) if a != "cem" else (True,):
        pol = _load(run, a, deterministic=mode)
        if a != "cem":
            pol.seed(eval_seed)
        env = make_env(task, **pol.metadata.get("env_kwargs", {}))
        try:
            done["deterministic" if mode else "stochastic"] = _held_out(env, pol, held_seeds, eval_seed)
        finally:
            env.close()
    write_json(run / "heldout.json", done)
    return done


def _job(job: _Job) -> dict:
    """A worker's run (in a spawned process or a Ray actor): its log lines go to stderr."""
    import sys

    return _train_and_evaluate(*job, log=lambda msg: print(msg, file=sys.stderr, flush=True))


def _no_setup() -> None:
    pass


def _train_all(todo: list[_Job], workers: int, backend: str, ray_address: str | None, log) -> list[dict]:
    """The runs of ``todo``, in its order: in this process (``workers`` 1, local), on spawned
    processes, or on Ray actors (``psychophysics.backends``). Each run is seeded, so where it runs
    changes no number (its wall time aside)."""
    if not todo:
        return []
    if backend == "ray":
        from ..psychophysics.backends import ray_map

        out: list = [None] * len(todo)

        def done(k: int, result: list) -> None:
            out[k] = result[0]

        ray_map(_no_setup, (), _jobs, [[job] for job in todo], done, workers=workers, address=ray_address)
        return out
    if workers == 1 or len(todo) == 1:
        return [_train_and_evaluate(*job, log=log) for job in todo]
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(min(workers, len(todo)), mp_context=mp.get_context("spawn")) as pool:
        return list(pool.map(_job, todo))


def _jobs(batch: list[tuple]) -> list[dict]:
    return [_job(job) for job in batch]


def _check_study(path: Path, study: dict) -> None:
    if path.exists():
        try:
            old = json.loads(path.read_text())
        except (ValueError, UnicodeDecodeError) as err:
            raise ValueError(
                f"{path} is not valid JSON ({err}): this folder's study cannot be read; use another --out"
            ) from None
        new = json.loads(json.dumps(study))  # as it reads back (tuples as lists)
        if old != new:
            diff = sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k))
            raise ValueError(
                f"{path.parent} holds another baselines study (differs in: {', '.join(diff)}); "
                "use another --out, or the same options to resume it"
            )
    else:
        write_json(path, study)


def _reference(path: Path, task: str, image_size: int, seeds: np.ndarray, eval_seed: int, log) -> dict[str, dict]:
    """The heuristic's and random cells' held-out results (computed once, then read)."""
    from .policies import BrightestCellPolicy, RandomPolicy

    try:
        ref = json.loads(path.read_text())
        if set(ref) == {"heuristic", "random"}:
            return ref
    except (OSError, ValueError, UnicodeDecodeError):
        pass
    log(f"baselines {task}: evaluating the heuristic and random cells on {len(seeds)} held-out episodes ...")
    env = make_env(task, image_size=image_size)
    try:
        g = env.vision.grid
        ref = {
            "heuristic": _held_out(env, BrightestCellPolicy(), seeds, eval_seed),
            "random": _held_out(env, RandomPolicy(g.M * g.N), seeds, eval_seed),
        }
    finally:
        env.close()
    write_json(path, ref)
    return ref


NAMES = {
    "ppo": "PPO",
    "sac": "SAC",
    "cem": "CEM linear cell policy",
    "heuristic": "heuristic (brightest cell)",
    "random": "random (uniform cell)",
}


def _name(agent: str, runs: list[dict]) -> str:
    """The table's name of an agent: PPO/SAC with the action their hyper-parameters chose."""
    if agent not in ("ppo", "sac"):
        return NAMES[agent]
    mode = ((runs[0].get("hyperparams") or {}).get("env_kwargs") or {}).get("action_mode", "cell")
    return f"{NAMES[agent]} (cortical conv, {'Box saccade' if mode == 'vector' else 'cell action'})"


def _table(out: Path, task: str, results: dict[str, list[dict]], reference: dict[str, dict]) -> list[dict]:
    """Write table.csv, table.md and curves.png; return the rows."""
    from .curve import plot_runs, read_training_log

    rows = []

    def row(name: str, runs: list[dict], mode: str) -> dict:
        sr = [r[mode]["success_rate"] for r in runs]
        s = summarize_runs(sr)
        return {
            "agent": name,
            "actions": mode,
            "seeds": " ".join(str(r["seed"]) for r in runs),
            "iqm": round(s["iqm"], 4),
            "ci_low": round(s["ci_low"], 4),
            "ci_high": round(s["ci_high"], 4),
            "mean": round(s["mean"], 4),
            "per_seed": " ".join(f"{v:.2f}" for v in sr),
            "mean_return": round(float(np.mean([r[mode]["mean_reward"] for r in runs])), 4),
            "env_steps": " ".join(str(r["env_steps"]) for r in runs),
            "wall_s": " ".join(f"{r['wall_s']:.0f}" for r in runs),
        }

    for a, runs in results.items():
        rows.append(row(_name(a, runs), runs, "deterministic"))
        if all("stochastic" in r for r in runs):
            rows.append(row(_name(a, runs), runs, "stochastic"))
    for k, v in reference.items():
        rows.append(
            {
                "agent": NAMES[k],
                "actions": "-",
                "seeds": "-",
                "iqm": v["success_rate"],
                "ci_low": "",
                "ci_high": "",
                "mean": v["success_rate"],
                "per_seed": "",
                "mean_return": round(v["mean_reward"], 4),
                "env_steps": "",
                "wall_s": "",
            }
        )
    write_csv(out / "table.csv", list(rows[0]), rows)
    md = [
        "| agent | actions | seeds | held-out success IQM [95 % CI] | per seed | mean return | env steps | wall s |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        ci = f" [{r['ci_low']:.2f}, {r['ci_high']:.2f}]" if r["ci_low"] != "" else ""
        md.append(
            f"| {r['agent']} | {r['actions']} | {r['seeds']} | {r['iqm']:.2f}{ci} | {r['per_seed']} | "
            f"{r['mean_return']:+.3f} | {r['env_steps']} | {r['wall_s']} |"
        )
    atomic_write_text(out / "table.md", "\n".join(md) + "\n")
    curves = {
        _name(a, runs): [read_training_log(_run_dir(out, a, r["seed"]) / "training_log.csv") for r in runs]
        for a, runs in results.items()
        if a != "cem"
    }
    lines = {}
    if "cem" in results:
        sr = [r["deterministic"]["success_rate"] for r in results["cem"]]
        ret = [r["deterministic"]["mean_reward"] for r in results["cem"]]
        lines[f"{NAMES['cem']}, held-out IQM"] = {
            "success_rate": summarize_runs(sr)["iqm"],
            "mean_return": summarize_runs(ret)["iqm"],
        }
    for k, v in reference.items():
        lines[f"{NAMES[k]}, held-out"] = {"success_rate": v["success_rate"], "mean_return": v["mean_reward"]}
    keys: tuple[str, ...] = ("success_rate", "mean_return", "train_success_rate")
    if not curves and "cem" in results:  # CEM alone: its validation curve (training_log.csv, a row per iteration)
        logs = [read_training_log(_run_dir(out, "cem", r["seed"]) / "training_log.csv") for r in results["cem"]]
        curves = {_name("cem", results["cem"]): [{**log, "mean_return": log["mean_reward"]} for log in logs]}
        keys = ("success_rate", "mean_return")
    if curves:
        plot_runs(
            curves,
            lines,
            out / "curves.png",
            keys=keys,
            title=f"{task}: IQM over seeds with a bootstrap 95 % band; lines: held-out",
        )
    return rows
