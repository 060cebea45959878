"""Stable-Baselines3 recipe: PPO with ``MultiInputPolicy`` on the cell-action saccade env.

The flat-MLP baseline of the README's ablation: it does not learn ``fixate`` at these budgets. The
agents that do are ``python -m experiments train --algo ppo|sac`` (:mod:`experiments.agents.sb3`: the
wrap-around cortical convolution, the continuous saccade and potential-based shaping).

Needs the optional ``rl`` extra (``stable-baselines3``, which needs torch; on Linux a plain
``pip install torch`` brings the CUDA build, several GB: on a CPU-only machine install PyTorch's
CPU wheel first)::

    pip install -e ".[rl]"
    python -m experiments.sb3_recipe --out runs/ppo_fixate --timesteps 2048 --n-envs 2
    python -m experiments evaluate --task fixate --policy runs/ppo_fixate --episodes 100 --seed 1

Training prints one progress line per PPO rollout (steps, elapsed time, the rollout's episode
success rate and return). The saved folder (``ppo_<task>.zip`` + ``ppo.json``) is loaded by
``python -m experiments evaluate --policy DIR`` (:class:`SB3Policy`), which runs the same episodes
as for the other policies.

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

from experiments.cli import int_in, out_dir
from experiments.agents.rollout import DEFAULT_ENV_KWARGS, EVAL_STREAM, episode_seeds, make_env

__all__ = ["SB3Policy", "evaluate_ppo", "load_sb3_policy", "main", "make_vec", "train_ppo", "PPO_META"]

#: The metadata file that marks a folder written by :func:`train_ppo`.
PPO_META = "ppo.json"


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


def _progress_callback(total: int, stream=None):
    """An SB3 callback printing one line per rollout: steps done, elapsed time, and the success
    rate and mean return of the episodes that ended in that rollout."""
    import time

    from stable_baselines3.common.callbacks import BaseCallback

    class Progress(BaseCallback):
        def _on_training_start(self) -> None:
            self.t0, self.succ, self.rets, self.ret = time.perf_counter(), [], [], None

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
            stats = (f"{k} episodes ended, success {sum(self.succ) / k:.2f}, mean return {sum(self.rets) / k:+.3f}"
                     if k else "no episode ended")
            print(f"ppo: {self.num_timesteps}/{total} steps, {el:.0f} s; this rollout: {stats}",
                  file=stream or sys.stderr, flush=True)
            self.succ, self.rets = [], []

    return Progress()


def train_ppo(out: str | Path, total_timesteps: int = 4096, n_envs: int = 2, n_steps: int = 256,
              vec: str = "subproc", seed: int = 0, task: str = "fixate",
              env_kwargs: dict[str, Any] | None = None, progress: bool = True) -> Path:
    """Train PPO (``MultiInputPolicy``) and save ``ppo_<task>.zip`` plus ``ppo.json`` into ``out``;
    with ``progress`` one line per rollout goes to stderr."""
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
        model.learn(total_timesteps=total_timesteps, progress_bar=False,
                    callback=_progress_callback(total_timesteps) if progress else None)
        path = out / f"ppo_{task}.zip"
        model.save(path)
    finally:
        venv.close()
    meta = {"task": task, "env_kwargs": {**DEFAULT_ENV_KWARGS, **(env_kwargs or {})}, "seed": seed,
            "total_timesteps": total_timesteps, "n_envs": n_envs, "n_steps": n_steps, "vec": vec,
            "sb3_version": sb3.__version__}
    (out / PPO_META).write_text(json.dumps(meta, indent=2) + "\n")
    return path


class SB3Policy:
    """A saved SB3 model as a cell policy (``experiments.agents.Policy``): acts deterministically."""

    def __init__(self, model, metadata: dict[str, Any], path: Path) -> None:
        self.model, self.metadata, self.path = model, metadata, path
        self.name = f"ppo:{path}"

    def act(self, obs: dict, rng=None) -> int:
        a, _ = self.model.predict(obs, deterministic=True)
        return int(a)


def load_sb3_policy(directory: str | Path) -> SB3Policy:
    """Load the folder written by :func:`train_ppo` (``ppo.json`` and ``ppo_<task>.zip``)."""
    d = Path(directory)
    meta_path = d / PPO_META
    if not meta_path.is_file():
        raise FileNotFoundError(f"{d} is not a saved PPO model: missing {PPO_META}")
    try:
        meta = json.loads(meta_path.read_text())
        task, env_kwargs = meta["task"], meta["env_kwargs"]
    except (json.JSONDecodeError, UnicodeDecodeError, KeyError, TypeError) as err:
        raise ValueError(f"{meta_path} is not a valid PPO metadata file ({err}); retrain with the SB3 recipe") from None
    zip_path = d / f"ppo_{task}.zip"
    if not zip_path.is_file():
        raise FileNotFoundError(f"{d} is not a saved PPO model: missing {zip_path.name}")
    sb3 = _require_sb3()
    try:
        model = sb3.PPO.load(zip_path, device="cpu")
    except Exception as err:  # SB3 raises zipfile/pickle/torch errors of many kinds for a corrupt file
        raise ValueError(f"{zip_path} could not be loaded by stable-baselines3 ({type(err).__name__}: {err}); "
                         "retrain with the SB3 recipe") from None
    return SB3Policy(model, {"task": task, "env_kwargs": dict(env_kwargs), **meta}, d)


def evaluate_ppo(path: str | Path, episodes: int = 50, seed: int = 0) -> dict:
    """Evaluate a saved PPO model (its ``.zip`` or its folder) on the same episodes, with the same
    rollout, as ``python -m experiments evaluate``."""
    from experiments.agents.rollout import evaluate

    path = Path(path)
    policy = load_sb3_policy(path.parent if path.suffix == ".zip" else path)
    env = make_env(policy.metadata["task"], **policy.metadata["env_kwargs"])
    try:
        res = evaluate(env, policy, episode_seeds(seed, episodes, EVAL_STREAM), rng_seed=seed)
    finally:
        env.close()
    return {**res.as_dict(), "seed": seed, "policy": str(path)}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m experiments.sb3_recipe",
                                description="PPO (Stable-Baselines3, MultiInputPolicy) on the cell-action saccade env; "
                                            "saves the model and prints one JSON line of evaluation results.")
    p.add_argument("--out", required=True, type=out_dir, help="output directory")
    p.add_argument("--task", choices=("fixate", "search"), default="fixate", help="env task (default fixate)")
    p.add_argument("--timesteps", type=int_in(1, 10**8), default=4096, help="total env steps (saccades) (default 4096)")
    p.add_argument("--n-envs", type=int_in(1, 64), default=2, help="parallel envs (default 2)")
    p.add_argument("--n-steps", type=int_in(2, 10**6), default=256, help="PPO rollout length per env (default 256)")
    p.add_argument("--vec", choices=("subproc", "dummy"), default="subproc",
                   help="SubprocVecEnv with spawn (default) or DummyVecEnv")
    p.add_argument("--seed", type=int_in(0, 2**32 - 1), default=0, help="seed (default 0)")
    p.add_argument("--eval-episodes", type=int_in(1, 10**6), default=50, help="evaluation episodes after training (default 50)")
    p.add_argument("--no-progress", action="store_true", help="no progress line per rollout")
    args = p.parse_args(argv)
    try:
        path = train_ppo(args.out, args.timesteps, args.n_envs, args.n_steps, args.vec, args.seed, args.task,
                         progress=not args.no_progress)
        res = evaluate_ppo(path, args.eval_episodes, args.seed)
    except (ValueError, ImportError) as err:
        print(f"sb3_recipe: error: {err}", file=sys.stderr)
        return 2
    print(json.dumps(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
