"""Stable-Baselines3 recipe: PPO with ``MultiInputPolicy`` on the cell-action saccade env.

Needs the optional ``rl`` extra (``stable-baselines3``, which needs torch). Install the CPU
torch wheel first, or pip pulls several GB of CUDA packages::

    pip install torch==2.13.0          # CPU wheel
    pip install -e ".[rl]"
    python -m experiments.sb3_recipe --out runs/ppo --timesteps 4096 --n-envs 2

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

__all__ = ["evaluate_ppo", "main", "make_vec", "train_ppo"]


def _require_sb3():
    try:
        import stable_baselines3
    except ImportError as err:  # pragma: no cover - depends on the optional extra
        raise ImportError("the SB3 recipe needs the 'rl' extra: pip install torch==2.13.0 (CPU) "
                          "then pip install -e '.[rl]'") from err
    return stable_baselines3


def make_vec(n_envs: int = 2, vec: str = "subproc", seed: int = 0, task: str = "fixate",
             env_kwargs: dict[str, Any] | None = None):
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
        return make_vec_env(make_env, n_envs=n_envs, seed=seed, env_kwargs=kwargs,
                            vec_env_cls=SubprocVecEnv, vec_env_kwargs={"start_method": "spawn"})
    return make_vec_env(make_env, n_envs=n_envs, seed=seed, env_kwargs=kwargs, vec_env_cls=DummyVecEnv)


def train_ppo(out: str | Path, total_timesteps: int = 4096, n_envs: int = 2, n_steps: int = 256,
              vec: str = "subproc", seed: int = 0, task: str = "fixate",
              env_kwargs: dict[str, Any] | None = None) -> Path:
    """Train PPO (``MultiInputPolicy``) and save ``ppo_<task>.zip`` plus ``ppo.json`` into ``out``."""
    sb3 = _require_sb3()
    if total_timesteps < 1 or n_steps < 2:
        raise ValueError("total_timesteps must be >= 1 and n_steps >= 2")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    venv = make_vec(n_envs, vec, seed, task, env_kwargs)
    try:
        batch = min(64, n_steps * n_envs)
        model = sb3.PPO("MultiInputPolicy", venv, n_steps=n_steps, batch_size=batch, gamma=0.9,
                        seed=seed, device="cpu", verbose=0)
        model.learn(total_timesteps=total_timesteps, progress_bar=False)
        path = out / f"ppo_{task}.zip"
        model.save(path)
    finally:
        venv.close()
    meta = {"task": task, "env_kwargs": {**DEFAULT_ENV_KWARGS, **(env_kwargs or {})}, "seed": seed,
            "total_timesteps": total_timesteps, "n_envs": n_envs, "n_steps": n_steps, "vec": vec,
            "sb3_version": sb3.__version__}
    (out / "ppo.json").write_text(json.dumps(meta, indent=2) + "\n")
    return path


def evaluate_ppo(path: str | Path, episodes: int = 50, seed: int = 0, deterministic: bool = True) -> dict:
    """Evaluate a saved PPO model on the same episodes as ``python -m experiments evaluate``."""
    sb3 = _require_sb3()
    path = Path(path)
    meta_path = path.parent / "ppo.json"
    meta = json.loads(meta_path.read_text()) if meta_path.exists() else {"task": "fixate", "env_kwargs": {}}
    model = sb3.PPO.load(path, device="cpu")
    env = make_env(meta["task"], **meta["env_kwargs"])
    try:
        rets, sacc, succ = [], [], []
        for s in episode_seeds(seed, episodes, EVAL_STREAM):
            obs, _ = env.reset(seed=int(s))
            total, n, done, ok = 0.0, 0, False, False
            while not done:
                a, _ = model.predict(obs, deterministic=deterministic)
                obs, r, term, trunc, info = env.step(int(a))
                total, n, ok, done = total + r, n + 1, bool(info["success"]), term or trunc
            rets.append(total), sacc.append(n), succ.append(ok)
    finally:
        env.close()
    k = len(rets)
    return {"success_rate": sum(succ) / k, "mean_reward": sum(rets) / k, "mean_saccades": sum(sacc) / k,
            "episodes": k, "seed": seed, "policy": str(path)}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m experiments.sb3_recipe",
                                description="PPO (Stable-Baselines3, MultiInputPolicy) on the cell-action saccade env; "
                                            "saves the model and prints one JSON line of evaluation results.")
    p.add_argument("--out", required=True, type=Path, help="output directory")
    p.add_argument("--task", choices=("fixate", "search"), default="fixate", help="env task (default fixate)")
    p.add_argument("--timesteps", type=int, default=4096, help="total env steps (saccades) (default 4096)")
    p.add_argument("--n-envs", type=int, default=2, help="parallel envs (default 2)")
    p.add_argument("--n-steps", type=int, default=256, help="PPO rollout length per env (default 256)")
    p.add_argument("--vec", choices=("subproc", "dummy"), default="subproc",
                   help="SubprocVecEnv with spawn (default) or DummyVecEnv")
    p.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    p.add_argument("--eval-episodes", type=int, default=50, help="evaluation episodes after training (default 50)")
    args = p.parse_args(argv)
    try:
        path = train_ppo(args.out, args.timesteps, args.n_envs, args.n_steps, args.vec, args.seed, args.task)
        res = evaluate_ppo(path, args.eval_episodes, args.seed)
    except (ValueError, ImportError) as err:
        print(f"sb3_recipe: error: {err}", file=sys.stderr)
        return 2
    print(json.dumps(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
