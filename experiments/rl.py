"""``train`` and ``evaluate``: saccade agents on the cell-action ``BinocularSaccadeEnv``.

    python -m experiments train --task fixate --out DIR [--quick] [--seed S] [--iterations N ...]
    python -m experiments evaluate --task fixate --policy DIR|random|heuristic --episodes N --seed S
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .cli import int_in, out_dir

__all__ = ["add_subcommand", "evaluate_command", "train_command"]

TASKS = ("fixate", "search")


_positive = int_in(1, 10**6)
_seed = int_in(0, 2**32 - 1)
_image_size = int_in(16, 512)


def add_subcommand(subparsers) -> None:
    """Register ``train`` and ``evaluate``."""
    from .agents.cem import CEMConfig

    d = CEMConfig()
    p = subparsers.add_parser(
        "train", help="train a linear cell-map saccade policy with the cross-entropy method",
        description="Train a linear softmax policy over the superior-colliculus cell map "
                    "(action_mode='cell') with the noisy cross-entropy method. Writes policy.npz, "
                    "policy.json, training_log.csv (one row per iteration, written as it goes), "
                    "baselines.json and learning_curve.png into --out.")
    p.add_argument("--task", choices=TASKS, default="fixate", help="env task (default: fixate)")
    p.add_argument("--out", required=True, type=out_dir, help="output directory for the policy and logs")
    p.add_argument("--seed", type=_seed, default=0, help="random seed; the run is deterministic under it (default 0)")
    p.add_argument("--quick", action="store_true",
                   help="a short run (5 iterations, 12 candidates x 4 episodes, 16 validation episodes; ~15 s)")
    p.add_argument("--iterations", type=_positive, help=f"CEM iterations (default {d.iterations})")
    p.add_argument("--population", type=_positive, help=f"candidates per iteration (default {d.population})")
    p.add_argument("--episodes", type=_positive, help=f"training episodes per candidate (default {d.episodes})")
    p.add_argument("--eval-episodes", type=_positive,
                   help=f"validation episodes per iteration and for the baselines (default {d.eval_episodes})")
    p.add_argument("--image-size", type=_image_size, default=96,
                   help="pixels per side of each eye's image (default 96; the ~1 deg target is often lost at 64)")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    p.set_defaults(func=train_command)

    e = subparsers.add_parser(
        "evaluate", help="evaluate a saved, random or heuristic policy; prints one JSON line",
        description="Run N episodes (reset seeds derived from --seed) and print one JSON line with "
                    "success_rate, mean_reward (mean episode return), mean_saccades, episodes, seed, policy.")
    e.add_argument("--task", choices=TASKS, default="fixate", help="env task (default: fixate)")
    e.add_argument("--policy", required=True,
                   help="a folder written by 'train' or by the SB3 recipe (python -m experiments.sb3_recipe), or "
                        "'random' (uniform over cells), or 'heuristic' (saccade to the brightest cell)")
    e.add_argument("--episodes", type=_positive, default=100, help="number of episodes (default 100)")
    e.add_argument("--seed", type=_seed, default=0, help="evaluation seed (default 0)")
    e.add_argument("--image-size", type=_image_size,
                   help="image size for random/heuristic (default 96); a saved policy uses its own")
    e.add_argument("--no-progress", action="store_true", help="no progress bar (it goes to stderr; the JSON to stdout)")
    e.set_defaults(func=evaluate_command)


def train_command(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from .agents.cem import CEMConfig, train_cem
    from .agents.curve import plot_learning_curve

    cfg = CEMConfig.quick() if args.quick else CEMConfig()
    over = {k: getattr(args, a) for k, a in (("iterations", "iterations"), ("population", "population"),
                                             ("episodes", "episodes"), ("eval_episodes", "eval_episodes"))
            if getattr(args, a) is not None}
    cfg = replace(cfg, **over)
    try:
        cfg.validate()
        policy, meta = train_cem(args.out, task=args.task, config=cfg, seed=args.seed,
                                 env_kwargs={"image_size": args.image_size}, progress=not args.no_progress)
    except ValueError as err:
        print(f"train: error: {err}", file=sys.stderr)
        return 2
    png = plot_learning_curve(meta["curve"], meta["baselines"], Path(args.out) / "learning_curve.png",
                              title=f"{args.task}: CEM, seed {args.seed}, {args.image_size} px")
    last = meta["curve"][-1]
    print(json.dumps({"out": str(args.out), "iterations": last["iteration"], "success_rate": last["success_rate"],
                      "mean_reward": last["mean_reward"], "baselines": meta["baselines"], "figure": str(png)}))
    return 0


def evaluate_command(args: argparse.Namespace) -> int:
    from .agents.policies import BrightestCellPolicy, RandomPolicy, load_policy
    from .agents.rollout import EVAL_STREAM, episode_seeds, evaluate, make_env
    from .sb3_recipe import PPO_META

    env_kwargs: dict = {"image_size": args.image_size or 96}
    try:
        if args.policy in ("random", "heuristic"):
            policy = None
        elif (Path(args.policy) / PPO_META).exists():  # a folder written by the SB3 recipe
            from .sb3_recipe import load_sb3_policy

            policy = load_sb3_policy(args.policy)
        else:
            policy = load_policy(args.policy)
        if policy is not None:
            saved_task = policy.metadata.get("task", args.task)
            if saved_task != args.task:
                raise ValueError(f"policy {args.policy} was trained on task {saved_task!r}, not {args.task!r}")
            env_kwargs = dict(policy.metadata.get("env_kwargs", {}))
            if args.image_size and args.image_size != env_kwargs.get("image_size", 96):
                raise ValueError(f"policy {args.policy} was trained at image size "
                                 f"{env_kwargs.get('image_size')}; drop --image-size")
        env = make_env(args.task, **env_kwargs)
    except (ValueError, TypeError, FileNotFoundError, ImportError) as err:
        print(f"evaluate: error: {err}", file=sys.stderr)
        return 2
    try:
        if policy is None:
            g = env.vision.grid
            policy = RandomPolicy(g.M * g.N) if args.policy == "random" else BrightestCellPolicy()
        try:
            res = evaluate(env, policy, episode_seeds(args.seed, args.episodes, EVAL_STREAM), rng_seed=args.seed,
                           progress=not args.no_progress)
        except ValueError as err:
            print(f"evaluate: error: {err}", file=sys.stderr)
            return 2
    finally:
        env.close()
    print(json.dumps({**res.as_dict(), "seed": args.seed, "policy": args.policy, "task": args.task}))
    return 0
