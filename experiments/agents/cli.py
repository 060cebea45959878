"""``train`` and ``evaluate``: saccade agents on ``BinocularSaccadeEnv``.

    python -m experiments train --algo cem|ppo|sac --task fixate|search --out DIR [--quick] [--seed S] ...
    python -m experiments evaluate --task fixate --policy DIR|random|heuristic --episodes N --seed S [--stochastic]
    python -m experiments baselines --task fixate --agents ppo sac cem --seeds 0 1 2 --out DIR

``--algo cem`` (default): the linear cell policy of :mod:`experiments.agents.cem`; ``ppo`` / ``sac``:
Stable-Baselines3 with the hyper-parameters of ``experiments/hyperparams/<algo>.yml``
(:mod:`experiments.agents.sb3`; needs the ``rl`` extra).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ..cli import int_in, out_dir
from ..cli.options import (
    TASKS,
    add_backend_options,
    add_workers_option,
    check_backend_options,
    image_size_type,
    seed_type,
)

__all__ = ["add_subcommand", "baselines_command", "evaluate_command", "train_command"]

_positive = int_in(1, 10**6)
_seed = seed_type()
_image_size = image_size_type()


def add_subcommand(subparsers) -> None:
    """Register ``train`` and ``evaluate``."""
    from .cem import CEMConfig

    d = CEMConfig()
    p = subparsers.add_parser(
        "train",
        help="train a saccade agent: CEM linear cell policy (default), PPO or SAC",
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
    p.add_argument("--task", choices=TASKS, default="fixate", help="env task (default: fixate)")
    p.add_argument("--out", required=True, type=out_dir, help="output directory for the policy and logs")
    p.add_argument("--seed", type=_seed, default=0, help="random seed; the run is deterministic under it (default 0)")
    p.add_argument(
        "--quick",
        action="store_true",
        help="a short run (cem: 5 iterations, 12 candidates x 4 episodes, 16 validation episodes, ~15 s; "
        "ppo/sac: 256 env steps, 4 validation episodes)",
    )
    p.add_argument(
        "--timesteps", type=_positive, help="ppo/sac: env steps (default: the hyper-parameter file's n_timesteps)"
    )
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
    p.add_argument(
        "--image-size",
        type=_image_size,
        help="pixels per side of each eye's image (default 96, or the hyper-parameter file's; the ~1 deg "
        "target is often lost at 64)",
    )
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
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
    p.set_defaults(func=train_command)

    e = subparsers.add_parser(
        "evaluate",
        help="evaluate a saved, random or heuristic policy; prints one JSON line",
        description="Run N episodes (reset seeds derived from --seed) and print one JSON line with "
        "success_rate, mean_reward (mean episode return), mean_saccades, episodes, seed, policy.",
    )
    e.add_argument("--task", choices=TASKS, default="fixate", help="env task (default: fixate)")
    e.add_argument(
        "--policy",
        required=True,
        help="a folder written by 'train' or by the SB3 recipe (python -m experiments.agents.sb3_recipe), or "
        "'random' (uniform over cells), or 'heuristic' (saccade to the brightest cell); these two "
        "bare names always mean the built-in policies (write ./random for a folder of that name); "
        "the output's 'source' says which was used",
    )
    e.add_argument("--episodes", type=_positive, default=100, help="number of episodes (default 100)")
    e.add_argument("--seed", type=_seed, default=0, help="evaluation seed (default 0)")
    e.add_argument(
        "--image-size",
        type=_image_size,
        help="image size for random/heuristic (default 96); a saved policy runs at its own (giving "
        "--image-size with a folder is an error)",
    )
    e.add_argument(
        "--stochastic",
        action="store_true",
        help="an SB3 policy samples its actions (seeded by --seed) instead of acting deterministically",
    )
    e.add_argument("--no-progress", action="store_true", help="no progress bar (it goes to stderr; the JSON to stdout)")
    e.set_defaults(func=evaluate_command)

    b = subparsers.add_parser(
        "baselines",
        help="train and evaluate agents x seeds on a task: IQM table with bootstrap CIs and curves",
        description="Train each agent with each seed (the runs of 'train --algo AGENT'), evaluate every run on "
        "the same held-out episodes (as 'evaluate --episodes N --seed S', deterministic and, for "
        "PPO/SAC, sampled actions) beside the heuristic and random cells, and write table.csv, "
        "table.md and curves.png (IQM over seeds, percentile-bootstrap 95% CI; Agarwal et al. "
        "2021). Runs already evaluated are kept: run the same command again to resume.",
    )
    b.add_argument("--task", choices=TASKS, default="fixate", help="env task (default: fixate)")
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
    b.add_argument("--timesteps", type=_positive, help="ppo/sac: env steps (default: the hyper-parameter files')")
    b.add_argument("--quick", action="store_true", help="tiny runs (ppo/sac 256 steps, cem --quick): a smoke test")
    b.add_argument("--image-size", type=_image_size, help="pixels per side of each eye's image (default 96)")
    b.add_argument("--ppo-hyperparams", type=Path, help="a YAML file instead of experiments/hyperparams/ppo.yml")
    b.add_argument("--sac-hyperparams", type=Path, help="a YAML file instead of experiments/hyperparams/sac.yml")
    add_workers_option(b, default=1, what="runs trained at once (processes / Ray actors)")
    add_backend_options(b, "where the runs train")
    b.set_defaults(func=baselines_command, _parser=b)


def _cem_config(args: argparse.Namespace):
    from dataclasses import replace

    from .cem import CEMConfig

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


def train_command(args: argparse.Namespace) -> int:
    """``train``: one run into ``--out`` (locked; another run's folder refused; resumed after an
    interruption); SIGINT/SIGTERM end it with one line and exit 130/143."""
    from ..cli import guarded
    from ..folders import LockBusyError

    if getattr(args, "engine", "single") == "batched":
        from .batched_cli import batched_train_command

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
    from ..folders import path_lock
    from .cem import train_cem
    from .curve import plot_learning_curve

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
    from ..folders import path_lock
    from .baselines import quick_hyperparams
    from .hyperparams import load_hyperparams
    from .sb3 import train_sb3

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


def evaluate_command(args: argparse.Namespace) -> int:
    """``evaluate``: a bare ``random`` or ``heuristic`` is always the built-in policy (a folder of
    that name is evaluated when written as a path, ``./random``); the JSON line's ``source`` says
    which was used."""
    from ..cli import guarded

    return guarded(
        "evaluate",
        lambda: _evaluate(args),
        resume_hint="nothing was written",
        errors={ValueError: 2, TypeError: 2, FileNotFoundError: 2, ImportError: 2},
    )


def _evaluate(args: argparse.Namespace) -> int:
    from .policies import BrightestCellPolicy, RandomPolicy, load_policy
    from .rollout import EVAL_STREAM, episode_seeds, evaluate, make_env

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
    if kind is None:
        policy = None
    elif kind in ("ppo", "sac"):
        from .batched_folder import is_batched_folder

        try:
            if kind == "ppo" and is_batched_folder(args.policy):  # a train --engine batched run: torch only
                from .batched_ppo import load_batched_agent as load_agent
            else:
                from .sb3 import load_agent
        except ImportError:
            raise ImportError(
                f"{args.policy} holds a {kind.upper()} model: evaluating it needs the 'rl' extra "
                "(pip install -e '.[rl]', CPU torch first)"
            ) from None
        policy = load_agent(args.policy, deterministic=not args.stochastic)
        policy.seed(args.seed)
    else:
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


def baselines_command(args: argparse.Namespace) -> int:
    """``baselines``: :func:`experiments.agents.baselines.run_baselines`; prints the Markdown table."""
    from ..cli import guarded
    from ..folders import LockBusyError
    from .baselines import run_baselines

    check_backend_options(args, args._parser)
    hyper = {k: v for k, v in (("ppo", args.ppo_hyperparams), ("sac", args.sac_hyperparams)) if v is not None}
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
