"""``python -m experiments evaluate``: evaluate a saved, random or heuristic policy
(``experiments.agents.rollout.evaluate``); prints one JSON line."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .commands import HELP
from .options import add_image_size_option, add_no_progress_option, add_seed_option, add_task_option
from .parsing import guarded, int_in

__all__ = ["BUILTIN_POLICIES", "add_subcommand", "run"]

_positive = int_in(1, 10**6)


def add_subcommand(subparsers) -> None:
    """Register ``evaluate``."""
    e = subparsers.add_parser(
        "evaluate",
        help=HELP["evaluate"],
        description="Run N episodes (reset seeds derived from --seed) and print one JSON line with "
        "success_rate, mean_reward (mean episode return), mean_saccades, episodes, seed, policy.",
    )
    add_task_option(e)
    e.add_argument(
        "--policy",
        required=True,
        help="a folder written by 'train' or by the SB3 recipe (python -m experiments.agents.sb3_recipe), or "
        "'random' (uniform over cells), or 'heuristic' (saccade to the brightest cell); these two "
        "bare names always mean the built-in policies (write ./random for a folder of that name); "
        "the output's 'source' says which was used",
    )
    e.add_argument("--episodes", type=_positive, default=100, help="number of episodes (default 100)")
    add_seed_option(e, "evaluation seed (default 0)")
    add_image_size_option(
        e,
        "image size for random/heuristic (default 96); a saved policy runs at its own (giving "
        "--image-size with a folder is an error)",
    )
    e.add_argument(
        "--stochastic",
        action="store_true",
        help="an SB3 policy samples its actions (seeded by --seed) instead of acting deterministically",
    )
    add_no_progress_option(e, "no progress bar (it goes to stderr; the JSON to stdout)")
    e.set_defaults(func=run)


BUILTIN_POLICIES = ("random", "heuristic")


def _policy_kind(d: Path) -> str:
    """Which trainer wrote the folder ``d``: "cem", "ppo" or "sac"; ``ValueError`` for a folder
    holding none or several (never guessed from a zip or a pickle)."""
    kinds = [k for k, f in (("cem", "policy.json"), ("ppo", "ppo.json"), ("sac", "sac.json")) if (d / f).is_file()]
    if len(kinds) > 1:
        raise ValueError(
            f"{d} holds {' and '.join(f'{k} metadata' for k in kinds)}: not one training run's "
            "folder; evaluate the folder train wrote"
        )
    if not kinds:
        if not d.is_dir():
            raise FileNotFoundError(
                f"{d} is not a saved policy: no such folder (built-in policies: {', '.join(BUILTIN_POLICIES)})"
            )
        unfinished = (
            " (train.json without a final model: an unfinished run; run its train command again)"
            if (d / "train.json").exists()
            else ""
        )
        raise FileNotFoundError(
            f"{d} is not a saved policy: missing policy.json (CEM), ppo.json or sac.json (PPO/SAC){unfinished}"
        )
    return kinds[0]


def run(args: argparse.Namespace) -> int:
    """``evaluate``: a bare ``random`` or ``heuristic`` is always the built-in policy (a folder of
    that name is evaluated when written as a path, ``./random``); the JSON line's ``source`` says
    which was used."""

    return guarded(
        "evaluate",
        lambda: _evaluate(args),
        resume_hint="nothing was written",
        errors={ValueError: 2, TypeError: 2, FileNotFoundError: 2, ImportError: 2},
    )


def _evaluate(args: argparse.Namespace) -> int:
    from ..agents.policies import BrightestCellPolicy, RandomPolicy, load_policy
    from ..agents.rollout import EVAL_STREAM, episode_seeds, evaluate, make_env

    env_kwargs: dict = {"image_size": args.image_size or 96}
    builtin = args.policy in BUILTIN_POLICIES
    if builtin and Path(args.policy).is_dir():
        print(
            f"evaluate: note: {args.policy!r} is the built-in policy; write ./{args.policy} to evaluate the "
            "folder of that name",
            file=sys.stderr,
        )
    kind = None if builtin else _policy_kind(Path(args.policy))
    if args.stochastic and kind not in ("ppo", "sac"):
        raise ValueError(
            "--stochastic applies to a Stable-Baselines3 policy folder (train --algo ppo|sac); "
            "the random, heuristic and CEM policies have one behaviour"
        )
    policy: Any = None  # None: a built-in policy, made once the env is
    if kind in ("ppo", "sac"):
        from ..agents.batched_folder import is_batched_folder

        load_agent: Callable[..., Any]
        try:
            if kind == "ppo" and is_batched_folder(args.policy):  # a train --engine batched run: torch only
                from ..agents.batched_ppo import load_batched_agent

                load_agent = load_batched_agent
            else:
                from ..agents.sb3 import load_agent as load_sb3_agent

                load_agent = load_sb3_agent
        except ImportError:
            raise ImportError(
                f"{args.policy} holds a {kind.upper()} model: evaluating it needs the 'rl' extra "
                "(pip install -e '.[rl]', CPU torch first)"
            ) from None
        policy = load_agent(args.policy, deterministic=not args.stochastic)
        policy.seed(args.seed)
    elif kind is not None:
        policy = load_policy(args.policy)
    if policy is not None:
        saved_task = policy.metadata.get("task", args.task)
        if saved_task != args.task:
            raise ValueError(f"policy {args.policy} was trained on task {saved_task!r}, not {args.task!r}")
        env_kwargs = dict(policy.metadata.get("env_kwargs", {}))
        if args.image_size:
            raise ValueError(
                f"--image-size applies to the built-in policies; policy {args.policy} runs at the "
                f"image size it was trained at ({env_kwargs.get('image_size')}): drop --image-size"
            )
    env = make_env(args.task, **env_kwargs)
    try:
        if policy is None:
            g = env.vision.grid
            policy = RandomPolicy(g.M * g.N) if args.policy == "random" else BrightestCellPolicy()
        res = evaluate(
            env,
            policy,
            episode_seeds(args.seed, args.episodes, EVAL_STREAM),
            rng_seed=args.seed,
            progress=not args.no_progress,
        )
    finally:
        env.close()
    source = "built-in" if builtin else f"folder ({kind})"
    print(
        json.dumps(
            {
                **res.as_dict(),
                "seed": args.seed,
                "policy": args.policy,
                "source": source,
                "task": args.task,
                **({"deterministic": not args.stochastic} if kind in ("ppo", "sac") else {}),
            }
        )
    )
    return 0
