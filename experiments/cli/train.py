"""``python -m experiments train``: train a saccade agent (CEM, or PPO/SAC with Stable-Baselines3;
``--engine batched``: ``experiments.agents.batched_cli``) into ``--out``."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .commands import HELP
from .options import (
    add_image_size_option,
    add_no_progress_option,
    add_quick_option,
    add_seed_option,
    add_task_option,
    add_timesteps_option,
)
from .parsing import guarded, int_in, out_dir

__all__ = ["add_subcommand", "run"]

_positive = int_in(1, 10**6)


def add_subcommand(subparsers) -> None:
    """Register ``train``."""
    from ..agents.cem import CEMConfig

    d = CEMConfig()
    p = subparsers.add_parser(
        "train",
        help=HELP["train"],
        description="--algo cem: a linear softmax policy over the superior-colliculus cell map "
        "(action_mode='cell') trained with the noisy cross-entropy method; writes train.json (the "
        "settings), training_log.csv (one row per iteration, written as it goes), baselines.json, "
        "learning_curve.png and policy.npz + policy.json into --out. --algo ppo|sac: "
        "Stable-Baselines3 with the wrap-around cortical convolution and the hyper-parameters of "
        "experiments/hyperparams/<algo>.yml; writes train.json, training_log.csv (one row per "
        "evaluation), learning_curve.png and <algo>.npz (weights) + <algo>.json (architecture, "
        "spaces, hyper-parameters, versions). Both replace checkpoint.npz (weights, optimizer and "
        "random state, SAC's replay buffer) after every evaluation: an interrupted run resumes, "
        "to the same weights, when the same command is run again; a folder holding another run "
        "is refused. Nothing is ever saved or loaded as pickle.",
    )
    p.add_argument("--algo", choices=("cem", "ppo", "sac"), default="cem", help="training algorithm (default: cem)")
    add_task_option(p)
    p.add_argument("--out", required=True, type=out_dir, help="output directory for the policy and logs")
    add_seed_option(p, "random seed; the run is deterministic under it (default 0)")
    add_quick_option(
        p,
        "a short run (cem: 5 iterations, 12 candidates x 4 episodes, 16 validation episodes, ~15 s; "
        "ppo/sac: 256 env steps, 4 validation episodes)",
    )
    add_timesteps_option(p, "ppo/sac: env steps (default: the hyper-parameter file's n_timesteps)")
    p.add_argument(
        "--hyperparams",
        type=Path,
        help="ppo/sac: a YAML file of per-task hyper-parameters (default experiments/hyperparams/<algo>.yml)",
    )
    p.add_argument("--iterations", type=_positive, help=f"CEM iterations (default {d.iterations})")
    p.add_argument("--population", type=_positive, help=f"candidates per iteration (default {d.population})")
    p.add_argument("--episodes", type=_positive, help=f"training episodes per candidate (default {d.episodes})")
    p.add_argument(
        "--eval-episodes",
        type=_positive,
        help=f"validation episodes per iteration and for the baselines (default {d.eval_episodes})",
    )
    add_image_size_option(
        p,
        "pixels per side of each eye's image (default 96, or the hyper-parameter file's; the ~1 deg "
        "target is often lost at 64)",
    )
    add_no_progress_option(p, "hide the progress bar")
    p.add_argument(
        "--engine",
        choices=("single", "batched"),
        default="single",
        help="single (default): BinocularSaccadeEnv on the CPU; batched: PPO on envs.BatchedBinocularSaccade "
        "(MuJoCo Warp, needs the gpu extra) with experiments/hyperparams/ppo_batched.yml",
    )
    p.add_argument("--device", help="--engine batched: cuda, cuda:<index> or cpu (default: cuda when available)")
    p.add_argument(
        "--num-envs",
        type=int_in(1, 65536),
        help="--engine batched: worlds stepped together (default: the hyper-parameter file's num_envs)",
    )
    p.set_defaults(func=run)


def _cem_config(args: argparse.Namespace):
    from dataclasses import replace

    from ..agents.cem import CEMConfig

    cfg = CEMConfig.quick() if args.quick else CEMConfig()
    over = {
        k: getattr(args, a)
        for k, a in (
            ("iterations", "iterations"),
            ("population", "population"),
            ("episodes", "episodes"),
            ("eval_episodes", "eval_episodes"),
        )
        if getattr(args, a) is not None
    }
    return replace(cfg, **over)


TRAIN_RESUME = "what finished is kept in --out: run the same command again to resume"


def run(args: argparse.Namespace) -> int:
    """``train``: one run into ``--out`` (locked; another run's folder refused; resumed after an
    interruption); SIGINT/SIGTERM end it with one line and exit 130/143."""
    from ..folders import LockBusyError

    if getattr(args, "engine", "single") == "batched":
        from ..agents.batched_cli import batched_train_command

        return batched_train_command(args)
    if getattr(args, "device", None) is not None or getattr(args, "num_envs", None) is not None:
        print("train: error: --device and --num-envs apply to --engine batched only", file=sys.stderr)
        return 2
    if args.algo != "cem":
        cem_only = [
            o
            for o, a in (("--iterations", "iterations"), ("--population", "population"), ("--episodes", "episodes"))
            if getattr(args, a) is not None
        ]
        if cem_only:
            print(f"train: error: {', '.join(cem_only)} apply to --algo cem only", file=sys.stderr)
            return 2
        try:
            import stable_baselines3  # noqa: F401  (imported only to check that it is installed)
        except ImportError:
            print(
                "train: error: --algo ppo/sac needs the 'rl' extra: pip install -e '.[rl]' (CPU torch first)",
                file=sys.stderr,
            )
            return 2
    elif args.timesteps is not None or args.hyperparams is not None:
        opt = "--timesteps" if args.timesteps is not None else "--hyperparams"
        print(
            f"train: error: {opt} applies to --algo ppo|sac only (CEM's budget is --iterations, --population, "
            "--episodes)",
            file=sys.stderr,
        )
        return 2
    work = _train_cem if args.algo == "cem" else _train_sb3
    return guarded(
        "train",
        lambda: work(args),
        resume_hint=TRAIN_RESUME,
        errors={ValueError: 2, FileNotFoundError: 2, LockBusyError: 2},
    )


def _train_cem(args: argparse.Namespace) -> int:
    from ..agents.cem import train_cem
    from ..agents.curve import plot_learning_curve
    from ..folders import path_lock

    cfg = _cem_config(args)
    cfg.validate()
    Path(args.out).mkdir(parents=True, exist_ok=True)
    with path_lock(Path(args.out) / ".lock", f"the training folder {args.out}"):
        policy, meta = train_cem(
            args.out,
            task=args.task,
            config=cfg,
            seed=args.seed,
            env_kwargs={"image_size": args.image_size or 96},
            progress=not args.no_progress,
        )
        png = plot_learning_curve(
            meta["curve"],
            meta["baselines"],
            Path(args.out) / "learning_curve.png",
            title=f"{args.task}: CEM, seed {args.seed}, {args.image_size or 96} px",
        )
    last = meta["curve"][-1]
    print(
        json.dumps(
            {
                "out": str(args.out),
                "iterations": last["iteration"],
                "success_rate": last["success_rate"],
                "mean_reward": last["mean_reward"],
                "baselines": meta["baselines"],
                "figure": str(png),
            }
        )
    )
    return 0


def _train_sb3(args: argparse.Namespace) -> int:
    """``train --algo ppo|sac``: :func:`experiments.agents.sb3.train_sb3` with the algorithm's YAML entry."""
    from ..agents.baselines import quick_hyperparams
    from ..agents.hyperparams import load_hyperparams
    from ..agents.sb3 import train_sb3
    from ..folders import path_lock

    hp = load_hyperparams(args.algo, args.task, args.hyperparams)
    if args.image_size:
        hp["env_kwargs"] = {**hp.get("env_kwargs", {}), "image_size": args.image_size}
    if args.eval_episodes:
        hp["eval_episodes"] = args.eval_episodes
    steps = args.timesteps
    if args.quick:
        steps = steps or 256
        hp = quick_hyperparams(args.algo, hp, args.eval_episodes)
    log = (lambda msg: None) if args.no_progress else (lambda msg: print(msg, file=sys.stderr, flush=True))
    Path(args.out).mkdir(parents=True, exist_ok=True)
    with path_lock(Path(args.out) / ".lock", f"the training folder {args.out}"):
        meta = train_sb3(args.out, args.algo, args.task, hp, seed=args.seed, timesteps=steps, log=log)
    last = meta["final"]
    print(
        json.dumps(
            {
                "out": str(args.out),
                "algo": args.algo,
                "env_steps": int(last["env_steps"]),
                "success_rate": float(last["success_rate"]),
                "mean_reward": float(last["mean_return"]),
                "wall_s": meta["wall_s"],
                "figure": str(Path(args.out) / "learning_curve.png"),
            }
        )
    )
    return 0
