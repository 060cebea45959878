"""``train --engine batched``: the options' checks and the run (:mod:`experiments.agents.batched_ppo`),
importable without torch, Warp or MuJoCo Warp (``python -m experiments train --help`` stays light)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

__all__ = ["QUICK", "batched_train_command"]

#: ``--quick``: two PPO updates of 2 steps per world, a validation row after each on 2 episodes, 4 held-out
#: episodes of at most 3 saccades, 32 px eyes (a smoke test of the whole path; about half a minute on Warp's
#: CPU backend, most of it the physics' kernel launches: ~300 per saccade, each paid from Python).
QUICK: dict[str, Any] = {
    "n_steps": 2,
    "n_minibatches": 2,
    "n_epochs": 2,
    "eval_every": 1,
    "eval_episodes": 2,
    "heldout_episodes": 4,
    "env_kwargs": {"image_size": 32, "task_kwargs": {"max_saccades": 3}},
}


def _usage(msg: str) -> int:
    print(f"train: error: {msg}", file=sys.stderr)
    return 2


def batched_train_command(args: argparse.Namespace) -> int:
    """``train --engine batched``: PPO only; CEM's options refused; the gpu extra required; one line
    for a device that is not here. Locked, resumable, SIGINT/SIGTERM exit 130/143 (``cli.guarded``)."""
    from ..cli import guarded
    from ..folders import LockBusyError

    if args.algo != "ppo":
        return _usage(f"--engine batched trains PPO only (--algo ppo); --algo {args.algo} runs on --engine single")
    cem_only = [
        o
        for o, a in (("--iterations", "iterations"), ("--population", "population"), ("--episodes", "episodes"))
        if getattr(args, a, None) is not None
    ]
    if cem_only:
        return _usage(f"{', '.join(cem_only)} apply to --algo cem only")
    try:
        import mujoco_warp  # noqa: F401
        import torch  # noqa: F401
        import warp  # noqa: F401
    except ImportError as err:
        return _usage(f"--engine batched needs the 'gpu' extra ({err.name} is missing): pip install -e '.[gpu]'")

    def work() -> int:
        from ..folders import path_lock
        from .batched_ppo import check_device, train_batched
        from .hyperparams import load_hyperparams

        check_device(args.device)  # before the folder is touched
        hp = load_hyperparams("ppo_batched", args.task, args.hyperparams)
        if args.image_size:
            hp["env_kwargs"] = {**dict(hp.get("env_kwargs") or {}), "image_size": args.image_size}
        steps = args.timesteps
        if args.quick:
            hp = {
                **hp,
                **QUICK,
                "env_kwargs": {**QUICK["env_kwargs"], **({"image_size": args.image_size} if args.image_size else {})},
            }
            n = args.num_envs or 4
            steps = steps or 2 * n * QUICK["n_steps"]
            hp["num_envs"] = n
        if args.eval_episodes:
            hp["eval_episodes"] = args.eval_episodes
        log = (lambda msg: None) if args.no_progress else (lambda msg: print(msg, file=sys.stderr, flush=True))
        Path(args.out).mkdir(parents=True, exist_ok=True)
        with path_lock(Path(args.out) / ".lock", f"the training folder {args.out}"):
            meta = train_batched(
                args.out,
                args.task,
                hp,
                seed=args.seed,
                num_envs=args.num_envs,
                device=args.device,
                timesteps=steps,
                log=log,
            )
        last, held = meta["final"], meta["heldout_batched"]
        print(
            json.dumps(
                {
                    "out": str(args.out),
                    "algo": "ppo",
                    "engine": "batched",
                    "device": meta["device"],
                    "num_envs": meta["num_envs"],
                    "env_steps": int(meta["env_steps"]),
                    "success_rate": float(last["success_rate"]),
                    "heldout_success_rate": held["success_rate"],
                    "heldout_episodes": held["episodes"],
                    "wall_s": meta["wall_s"],
                    "train_steps_per_s": meta["train_steps_per_s"],
                    "figure": str(Path(args.out) / "learning_curve.png"),
                }
            )
        )
        return 0

    return guarded(
        "train",
        work,
        resume_hint="what finished is kept in --out: run the same command again to resume",
        errors={ValueError: 2, FileNotFoundError: 2, LockBusyError: 2},
    )
