"""Stable-Baselines3 recipe: PPO with ``MultiInputPolicy`` on the cell-action saccade env.

The flat-MLP baseline of the README's ablation: it does not learn ``fixate`` at these budgets. The
agents that do are ``python -m experiments train --algo ppo|sac`` (:mod:`experiments.agents.sb3`: the
wrap-around cortical convolution, the continuous saccade and potential-based shaping).

Needs the optional ``rl`` extra (``stable-baselines3``, which needs torch; on Linux a plain
``pip install torch`` brings the CUDA build, several GB: on a CPU-only machine install PyTorch's
CPU wheel first)::

    pip install -e ".[rl]"
    python -m experiments.agents.sb3_recipe --out runs/ppo_fixate --timesteps 2048 --n-envs 2
    python -m experiments evaluate --task fixate --policy runs/ppo_fixate --episodes 100 --seed 1

Training prints one progress line per PPO rollout (steps, elapsed time, the rollout's episode
success rate and return). The saved folder (``ppo.npz`` weights + ``ppo.json``: architecture,
spaces, settings; no pickle) is loaded by ``python -m experiments evaluate --policy DIR``
(:func:`experiments.agents.sb3.load_agent`), which runs the same episodes as for the other
policies. :func:`export_sb3_zip` writes SB3's own zip for SB3's tools: that zip is code (pickle),
and nothing here loads one.

The env is the same as the CEM agent's (:data:`experiments.agents.DEFAULT_ENV_KWARGS`: cell
actions, 96 px, dict observation ``cortical``/``fovea``/``remapped``/``eyes``), vectorised with
``SubprocVecEnv(start_method="spawn")`` (EGL contexts do not survive fork) or ``DummyVecEnv``.
PPO: Schulman et al. 2017; SB3: Raffin et al. 2021 (JMLR 22:268).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from experiments.agents.rollout import DEFAULT_ENV_KWARGS, EVAL_STREAM, episode_seeds, make_env
from experiments.cli import int_in, out_dir
from experiments.cli.options import (
    add_no_progress_option,
    add_seed_option,
    add_task_option,
    add_timesteps_option,
)
from experiments.folders import LockBusyError

__all__ = ["PPO_META", "evaluate_ppo", "export_sb3_zip", "load_sb3_policy", "main", "make_vec", "train_ppo"]

#: The metadata file that marks a folder written by :func:`train_ppo`.
PPO_META = "ppo.json"


def _require_sb3():
    try:
        import stable_baselines3
    except ImportError as err:  # pragma: no cover - depends on the optional extra
        raise ImportError(
            "the SB3 recipe needs the 'rl' extra: pip install torch==2.13.0 (CPU) then pip install -e '.[rl]'"
        ) from err
    return stable_baselines3


def make_vec(
    n_envs: int = 2, vec: str = "subproc", seed: int = 0, task: str = "fixate", env_kwargs: dict[str, Any] | None = None
):
    """``n_envs`` copies of the cell-action env in a ``SubprocVecEnv`` (spawn) or ``DummyVecEnv``."""
    _require_sb3()
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    if vec not in ("subproc", "dummy"):
        raise ValueError(f"vec must be 'subproc' or 'dummy'; got {vec!r}")
    if n_envs < 1:
        raise ValueError(f"n_envs must be >= 1; got {n_envs}")
    kwargs = {"task": task, **DEFAULT_ENV_KWARGS, **(env_kwargs or {})}
    if vec == "subproc":
        return make_vec_env(
            make_env,
            n_envs=n_envs,
            seed=seed,
            env_kwargs=kwargs,
            vec_env_cls=SubprocVecEnv,
            vec_env_kwargs={"start_method": "spawn"},
        )
    return make_vec_env(make_env, n_envs=n_envs, seed=seed, env_kwargs=kwargs, vec_env_cls=DummyVecEnv)


def _progress_callback(total: int, stream=None):
    """An SB3 callback printing one line per rollout: steps done, elapsed time, and the success
    rate and mean return of the episodes that ended in that rollout."""
    import time

    from stable_baselines3.common.callbacks import BaseCallback

    class Progress(BaseCallback):
        def _on_training_start(self) -> None:
            self.t0 = time.perf_counter()
            self.succ: list[bool] = []
            self.rets: list[float] = []
            self.ret: list[float] | None = None

        def _on_step(self) -> bool:
            rewards, dones = self.locals["rewards"], self.locals["dones"]
            if self.ret is None:
                self.ret = [0.0] * len(rewards)
            for i, (r, d, info) in enumerate(zip(rewards, dones, self.locals["infos"])):
                self.ret[i] += float(r)
                if d:
                    self.succ.append(bool(info.get("success", False)))
                    self.rets.append(self.ret[i])
                    self.ret[i] = 0.0
            return True

        def _on_rollout_end(self) -> None:
            el = time.perf_counter() - self.t0
            k = len(self.succ)
            stats = (
                f"{k} episodes ended, success {sum(self.succ) / k:.2f}, mean return {sum(self.rets) / k:+.3f}"
                if k
                else "no episode ended"
            )
            print(
                f"ppo: {self.num_timesteps}/{total} steps, {el:.0f} s; this rollout: {stats}",
                file=stream or sys.stderr,
                flush=True,
            )
            self.succ, self.rets = [], []

    return Progress()


def train_ppo(
    out: str | Path,
    total_timesteps: int = 4096,
    n_envs: int = 2,
    n_steps: int = 256,
    vec: str = "subproc",
    seed: int = 0,
    task: str = "fixate",
    env_kwargs: dict[str, Any] | None = None,
    progress: bool = True,
) -> Path:
    """Train PPO (``MultiInputPolicy``) and save it as data into ``out`` (locked while it runs):
    ``ppo.npz`` (weights) and ``ppo.json`` (architecture, spaces, settings, versions; written last),
    as :func:`experiments.agents.sb3.save_agent` does; with ``progress`` one line per rollout goes to
    stderr. Not resumable: an interrupted recipe starts again. Returns the weights' path."""
    sb3 = _require_sb3()
    from experiments.agents.sb3 import save_agent
    from experiments.folders import path_lock

    if total_timesteps < 1 or n_steps < 2:
        raise ValueError("total_timesteps must be >= 1 and n_steps >= 2")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with path_lock(out / ".lock", f"the recipe's folder {out}"):
        venv = make_vec(n_envs, vec, seed, task, env_kwargs)
        try:
            batch = min(64, n_steps * n_envs)
            model = sb3.PPO(
                "MultiInputPolicy",
                venv,
                n_steps=n_steps,
                batch_size=batch,
                gamma=0.9,
                seed=seed,
                device="cpu",
                verbose=0,
            )
            from experiments.agents.sb3 import silent_logger  # torch: imported with SB3 anyway

            model.set_logger(silent_logger())
            model.learn(
                total_timesteps=total_timesteps,
                progress_bar=False,
                callback=_progress_callback(total_timesteps) if progress else None,
            )
        finally:
            venv.close()
        meta = {
            "task": task,
            "env_kwargs": {**DEFAULT_ENV_KWARGS, **(env_kwargs or {})},
            "seed": seed,
            "total_timesteps": total_timesteps,
            "n_envs": n_envs,
            "n_steps": n_steps,
            "vec": vec,
            "policy": "mlp",
            "recipe": "sb3_recipe",
        }
        save_agent(out, model, "ppo", meta)
    return out / "ppo.npz"


def load_sb3_policy(directory: str | Path):
    """Load the folder written by :func:`train_ppo`: :func:`experiments.agents.sb3.load_agent`
    (the policy rebuilt from ``ppo.json``'s architecture, the weights read from ``ppo.npz``; no pickle)."""
    _require_sb3()
    from experiments.agents.sb3 import load_agent

    return load_agent(directory)


def export_sb3_zip(directory: str | Path, path: str | Path) -> Path:
    """Write the saved PPO/SAC policy of ``directory`` (a folder of ``train --algo ppo|sac`` or of this
    recipe) as a Stable-Baselines3 zip at ``path``, for SB3's own tools. Such a zip holds pickled
    Python objects: it is code, for your own machine; this package never loads one."""
    sb3 = _require_sb3()
    from stable_baselines3.common.vec_env import DummyVecEnv

    from experiments.agents.sb3 import load_agent

    agent = load_agent(directory)
    meta = agent.metadata
    cls = sb3.PPO if meta["algo"] == "ppo" else sb3.SAC

    def _make():
        from gymnasium.wrappers import FilterObservation

        env = make_env(meta["task"], **meta["env_kwargs"])
        return FilterObservation(env, list(agent.keys)) if agent.keys else env

    venv = DummyVecEnv([_make])
    try:
        kwargs = dict(meta["architecture"]["policy_kwargs"])
        use_sde = {"use_sde": bool(kwargs.pop("use_sde"))} if "use_sde" in kwargs else {}
        model = cls(type(agent.model), venv, device="cpu", verbose=0, policy_kwargs=kwargs or None, **use_sde)
        model.policy.load_state_dict(agent.model.state_dict())
        model.save(path)
    finally:
        venv.close()
    return Path(path)


def evaluate_ppo(path: str | Path, episodes: int = 50, seed: int = 0) -> dict:
    """Evaluate a saved PPO model (its folder or its ``ppo.npz``) on the same episodes, with the same
    rollout, as ``python -m experiments evaluate``."""
    from experiments.agents.rollout import evaluate

    path = Path(path)
    policy = load_sb3_policy(path.parent if path.suffix == ".npz" else path)
    env = make_env(policy.metadata["task"], **policy.metadata["env_kwargs"])
    try:
        res = evaluate(env, policy, episode_seeds(seed, episodes, EVAL_STREAM), rng_seed=seed)
    finally:
        env.close()
    return {**res.as_dict(), "seed": seed, "policy": str(path)}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m experiments.agents.sb3_recipe",
        description="PPO (Stable-Baselines3, MultiInputPolicy) on the cell-action saccade env; "
        "saves the model and prints one JSON line of evaluation results.",
    )
    p.add_argument("--out", required=True, type=out_dir, help="output directory")
    add_task_option(p)
    add_timesteps_option(p, "total env steps (saccades) (default 4096)", default=4096)
    p.add_argument("--n-envs", type=int_in(1, 64), default=2, help="parallel envs (default 2)")
    p.add_argument("--n-steps", type=int_in(2, 10**6), default=256, help="PPO rollout length per env (default 256)")
    p.add_argument(
        "--vec",
        choices=("subproc", "dummy"),
        default="subproc",
        help="SubprocVecEnv with spawn (default) or DummyVecEnv",
    )
    add_seed_option(p, "seed (default 0)")
    p.add_argument(
        "--eval-episodes", type=int_in(1, 10**6), default=50, help="evaluation episodes after training (default 50)"
    )
    add_no_progress_option(p, "no progress line per rollout")
    args = p.parse_args(argv)
    try:
        path = train_ppo(
            args.out,
            args.timesteps,
            args.n_envs,
            args.n_steps,
            args.vec,
            args.seed,
            args.task,
            progress=not args.no_progress,
        )
        res = evaluate_ppo(path, args.eval_episodes, args.seed)
    except (ValueError, ImportError, FileNotFoundError, LockBusyError) as err:
        print(f"sb3_recipe: error: {err}", file=sys.stderr)
        return 2
    print(json.dumps(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
