"""``python -m experiments baselines``: train and evaluate agents x seeds on a task
(``experiments.agents.baselines.run_baselines``): IQM table with bootstrap CIs and curves."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .commands import HELP
from .options import (
    add_backend_options,
    add_image_size_option,
    add_quick_option,
    add_task_option,
    add_timesteps_option,
    add_workers_option,
    check_backend_options,
    seed_type,
)
from .parsing import guarded, int_in, out_dir

__all__ = ["add_subcommand", "run"]

_positive = int_in(1, 10**6)
_seed = seed_type()


def add_subcommand(subparsers) -> None:
    """Register ``baselines``."""
    b = subparsers.add_parser(
        "baselines",
        help=HELP["baselines"],
        description="Train each agent with each seed (the runs of 'train --algo AGENT'), evaluate every run on "
        "the same held-out episodes (as 'evaluate --episodes N --seed S', deterministic and, for "
        "PPO/SAC, sampled actions) beside the heuristic and random cells, and write table.csv, "
        "table.md and curves.png (IQM over seeds, percentile-bootstrap 95% CI; Agarwal et al. "
        "2021). Runs already evaluated are kept: run the same command again to resume.",
    )
    add_task_option(b)
    b.add_argument(
        "--agents",
        nargs="+",
        choices=("ppo", "sac", "cem"),
        default=["ppo", "sac", "cem"],
        help="agents to train (default: ppo sac cem)",
    )
    b.add_argument("--seeds", nargs="+", type=_seed, default=[0, 1, 2], help="training seeds (default: 0 1 2)")
    b.add_argument("--out", required=True, type=out_dir, help="output directory (resumed if it holds the same study)")
    b.add_argument("--episodes", type=_positive, default=100, help="held-out episodes per run (default 100)")
    b.add_argument("--eval-seed", type=_seed, default=1, help="seed of the held-out episodes (default 1)")
    add_timesteps_option(b, "ppo/sac: env steps (default: the hyper-parameter files')")
    add_quick_option(b, "tiny runs (ppo/sac 256 steps, cem --quick): a smoke test")
    add_image_size_option(b, "pixels per side of each eye's image (default 96)")
    b.add_argument("--ppo-hyperparams", type=Path, help="a YAML file instead of experiments/hyperparams/ppo.yml")
    b.add_argument("--sac-hyperparams", type=Path, help="a YAML file instead of experiments/hyperparams/sac.yml")
    b.add_argument(
        "--cem-hyperparams",
        type=Path,
        help="a YAML file whose entry for --task sets CEM's iterations, population, episodes, elite_frac, "
        "init_std, ring_std, extra_std, eval_episodes (default: CEMConfig's, or --quick's)",
    )
    add_workers_option(b, default=1, what="runs trained at once (processes / Ray actors)")
    add_backend_options(b, "where the runs train")
    b.set_defaults(func=run, _parser=b)


def run(args: argparse.Namespace) -> int:
    """``baselines``: :func:`experiments.agents.baselines.run_baselines`; prints the Markdown table."""
    from ..agents.baselines import run_baselines
    from ..folders import LockBusyError

    check_backend_options(args, args._parser)
    hyper = {
        k: v
        for k, v in (("ppo", args.ppo_hyperparams), ("sac", args.sac_hyperparams), ("cem", args.cem_hyperparams))
        if v is not None
    }
    unused = [f"--{k}-hyperparams" for k in hyper if k not in args.agents]
    if args.timesteps is not None and not {"ppo", "sac"} & set(args.agents):
        unused.append("--timesteps")
    if unused:
        print(
            f"baselines: error: {', '.join(unused)} apply to agents not in --agents ({' '.join(args.agents)})",
            file=sys.stderr,
        )
        return 2

    def work() -> int:
        run_baselines(
            args.out,
            args.task,
            tuple(args.agents),
            tuple(args.seeds),
            episodes=args.episodes,
            eval_seed=args.eval_seed,
            timesteps=args.timesteps,
            quick=args.quick,
            image_size=args.image_size,
            hyperparams=hyper,
            log=lambda msg: print(msg, file=sys.stderr, flush=True),
            workers=args.workers,
            backend=args.backend,
            ray_address=args.ray_address,
        )
        print((Path(args.out) / "table.md").read_text(), end="")
        return 0

    return guarded(
        "baselines",
        work,
        resume_hint="finished runs are kept: run the same command again to resume",
        errors={ValueError: 2, FileNotFoundError: 2, LockBusyError: 1},
    )
