"""skrl recipe: PPO on the batched env (``envs.BatchedBinocularSaccade``), observations kept on the device.

Needs the ``gpu`` extra (mujoco-warp, warp-lang, torch, skrl)::

    pip install -e ".[gpu]"
    python -m experiments.agents.skrl_recipe --out runs/ppo_search --device cuda --num-envs 4096 --task search --timesteps 300
    python -m experiments.agents.skrl_recipe --out runs/ppo_cpu --device cpu --num-envs 8 --task fixate --timesteps 48

Why skrl (Serrano-Muñoz, Chrysostomou, Arana-Arexolaleiba & Arana-Arexolaleiba 2023, JMLR 24:254):
a maintained PyTorch RL library whose PPO stores rollouts as torch tensors on the env's device and
whose trainers already drive GPU-batched simulators (its wrappers for Isaac Lab, ManiSkill and
MuJoCo Playground); a gymnasium ``VectorEnv`` that returns torch tensors plugs in through one small
``Wrapper`` (:class:`DeviceVectorWrapper`), with no host copy of the observations. (rsl_rl is
leaner but tied to Isaac Lab's env interface; SB3 keeps its buffers in numpy on the host.)

The env runs with ``autoreset_mode="same_step"`` (what skrl's trainers expect: the observation after
a terminal step is the next episode's first; a truncation is reported to skrl as a termination, since
the saccade budget is not observed and the next observation belongs to the next episode). Observations ``cortical``, ``remapped``, ``fovea`` and
``eyes`` are flattened and concatenated on the device; the policy is a Gaussian MLP on the vector
action (the saccade, scaled by ``max_amplitude_deg``), the value an MLP; both standardised by skrl's
running scaler (``--policy mlp``, default); or ``--policy cortical``: the wrap-around convolution over the
cortical map (:mod:`experiments.agents.extractors`), whose cell-logit map is the categorical over cells
(``--action-mode cell``) or, through its soft-argmax, the mean saccade (``--action-mode vector``).
PPO: Schulman et al. 2017.

Writes ``learning_curve.csv`` (per rollout: env steps, finished episodes, their mean return and
success rate; a row appended after every rollout), ``learning_curve.png``, ``agent.npz`` (the agent's
state dicts as arrays, with the summary inside: :func:`save_weights`; no pickle) and ``ppo.json``
(the run's arguments, ``"format": "skrl-npz-1"``; ``python -m experiments evaluate`` does not load it).
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from experiments.cli import int_in, out_dir
from experiments.cli.options import (
    add_image_size_option,
    add_seed_option,
    add_task_option,
    add_timesteps_option,
)

from ..folders import save_figure, write_json

__all__ = ["DeviceVectorWrapper", "OBS_KEYS", "train", "main"]

#: The observations the policy sees, flattened and concatenated in this order.
OBS_KEYS = ("cortical", "remapped", "fovea", "eyes")


def _require():
    try:
        import skrl  # noqa: F401  (imported only to check that it is installed)
        import torch  # noqa: F401  (imported only to check that it is installed)

        from envs.batched_physics import require_gpu_extra
    except ImportError as e:
        sys.exit(f'this recipe needs the gpu extra ({e.name} is missing): pip install -e ".[gpu]"')
    require_gpu_extra()


def DeviceVectorWrapper(env):
    """Wrap a ``BatchedBinocularSaccade`` (``output="torch"``, ``autoreset_mode="same_step"``) as an skrl
    env: flat float32 observations (N, D) on the device, rewards and dones as (N, 1) tensors; keeps the
    finished episodes' returns and successes (``episodes``: (env steps, return, success) rows)."""
    import gymnasium
    import torch
    from skrl.envs.wrappers.torch.base import Wrapper

    class _Wrapper(Wrapper):
        def __init__(self, env) -> None:
            super().__init__(env)
            from gymnasium.vector import AutoresetMode

            if env.output != "torch" or env.autoreset_mode is not AutoresetMode.SAME_STEP:
                raise ValueError("wrap a BatchedBinocularSaccade(output='torch', autoreset_mode='same_step')")
            dim = sum(int(np.prod(env.single_observation_space[k].shape)) for k in OBS_KEYS)
            self._obs_space = gymnasium.spaces.Box(-np.inf, np.inf, (dim,), np.float32)
            self._returns = np.zeros(env.num_envs)
            self.env_steps = 0
            self.episodes: list[tuple[int, float, bool]] = []
            self.curve_path: Path | None = None  # set (with per_rollout) to append a curve row per rollout
            self.per_rollout = 1

        @property
        def observation_space(self):
            return self._obs_space

        @property
        def action_space(self):
            return self._unwrapped.single_action_space

        @property
        def state_space(self):
            return None

        @property
        def device(self):
            return self._unwrapped.device

        def _flat(self, obs) -> torch.Tensor:
            n = self._unwrapped.num_envs
            return torch.cat([obs[k].reshape(n, -1) for k in OBS_KEYS], dim=1)

        def reset(self):
            obs, info = self._env.reset()
            return self._flat(obs), info

        def step(self, actions):
            if isinstance(self.action_space, gymnasium.spaces.Discrete):  # skrl's (N, 1) cell indices
                actions = actions.view(-1).long()
            else:
                actions = actions.clamp(-1.0, 1.0)
            obs, reward, terminated, truncated, info = self._env.step(actions)
            dev = self.device
            done = np.asarray(terminated) | np.asarray(truncated)
            self.env_steps += self._unwrapped.num_envs
            self._returns += reward  # host numpy: no per-step device synchronisation for the bookkeeping
            for i in np.flatnonzero(done):
                self.episodes.append((self.env_steps, float(self._returns[i]), bool(info["final_info"]["success"][i])))
            self._returns[done] = 0.0
            if self.curve_path is not None and self.env_steps % self.per_rollout == 0:  # a rollout ended: its row
                rows = _curve(self.episodes, self.per_rollout, self.env_steps, start=self.env_steps - self.per_rollout)
                with open(self.curve_path, "a", newline="") as f:
                    csv.writer(f).writerows(rows)
            # The saccade budget is not in the observation, so a truncated episode is reported as terminated:
            # skrl would otherwise bootstrap its value from the next observation, which under the same-step
            # autoreset is already the next episode's first (a different, unrelated state).
            te = torch.as_tensor(done, device=dev).view(-1, 1)
            r = torch.as_tensor(reward, dtype=torch.float32, device=dev).view(-1, 1)
            return self._flat(obs), r, te, torch.zeros_like(te), info

        def state(self):
            return None

        def render(self, *args, **kwargs):
            return None

        def close(self) -> None:
            self._env.close()

    return _Wrapper(env)


def _cortical_models(obs_space, act_space, device, single_obs_space, vectors, channels: tuple[int, ...]):
    """Policy and value over the wrap-around cortical convolution (:class:`experiments.agents.extractors.
    CorticalEncoder`): the policy's per-cell logit map is the categorical over cells (``Discrete``) or, through
    its soft-argmax, the Gaussian's mean saccade (``Box``); the value reads the pooled features."""
    import gymnasium
    import torch
    from skrl.models.torch import CategoricalMixin, DeterministicMixin, GaussianMixin, Model
    from torch import nn

    from experiments.agents.extractors import CorticalEncoder, SoftArgmaxSaccade

    shapes = {k: tuple(single_obs_space[k].shape) for k in OBS_KEYS}
    sizes = [int(np.prod(shapes[k])) for k in OBS_KEYS]
    offsets = np.concatenate([[0], np.cumsum(sizes)])

    def unflatten(x: torch.Tensor) -> dict[str, torch.Tensor]:
        return {k: x[:, offsets[i] : offsets[i + 1]].reshape(-1, *shapes[k]) for i, k in enumerate(OBS_KEYS)}

    def encoder() -> CorticalEncoder:
        return CorticalEncoder(shapes["cortical"], shapes["fovea"], sizes[OBS_KEYS.index("eyes")], channels)

    discrete = isinstance(act_space, gymnasium.spaces.Discrete)

    class CellPolicy(CategoricalMixin, Model):
        def __init__(self):
            Model.__init__(self, observation_space=obs_space, action_space=act_space, device=device)
            CategoricalMixin.__init__(self, unnormalized_log_prob=True)
            self.enc = encoder()
            with torch.no_grad():
                self.enc.logit.weight.mul_(0.01)

        def compute(self, inputs, role=""):
            return self.enc(unflatten(inputs["observations"]))[0], {}

    class SaccadePolicy(GaussianMixin, Model):
        def __init__(self):
            Model.__init__(self, observation_space=obs_space, action_space=act_space, device=device)
            GaussianMixin.__init__(self, clip_actions=True, clip_log_std=True, min_log_std=-5, max_log_std=1)
            self.enc = encoder()
            self.saccade = SoftArgmaxSaccade(vectors)
            self.log_std = nn.Parameter(torch.full((act_space.shape[0],), -1.0))
            with torch.no_grad():
                self.enc.logit.weight.mul_(0.01)

        def compute(self, inputs, role=""):
            return self.saccade(self.enc(unflatten(inputs["observations"]))[0]), {"log_std": self.log_std}

    class Value(DeterministicMixin, Model):
        def __init__(self):
            Model.__init__(self, observation_space=obs_space, action_space=act_space, device=device)
            DeterministicMixin.__init__(self)
            self.enc = encoder()
            self.net = nn.Sequential(nn.Linear(self.enc.global_dim, 64), nn.Tanh(), nn.Linear(64, 1))

        def compute(self, inputs, role=""):
            return self.net(self.enc(unflatten(inputs["observations"]))[1]), {}

    return (CellPolicy() if discrete else SaccadePolicy()), Value()


def _models(obs_space, act_space, device, hidden: int):
    import torch
    from skrl.models.torch import DeterministicMixin, GaussianMixin, Model
    from torch import nn

    class Policy(GaussianMixin, Model):
        def __init__(self):
            Model.__init__(self, observation_space=obs_space, action_space=act_space, device=device)
            GaussianMixin.__init__(self, clip_actions=True, clip_log_std=True, min_log_std=-5, max_log_std=1)
            d = obs_space.shape[0]
            self.net = nn.Sequential(
                nn.Linear(d, hidden),
                nn.ELU(),
                nn.Linear(hidden, hidden // 2),
                nn.ELU(),
                nn.Linear(hidden // 2, act_space.shape[0]),
                nn.Tanh(),
            )
            self.log_std = nn.Parameter(torch.full((act_space.shape[0],), -0.7))

        def compute(self, inputs, role=""):
            return self.net(inputs["observations"]), {"log_std": self.log_std}

    class Value(DeterministicMixin, Model):
        def __init__(self):
            Model.__init__(self, observation_space=obs_space, action_space=act_space, device=device)
            DeterministicMixin.__init__(self)
            d = obs_space.shape[0]
            self.net = nn.Sequential(
                nn.Linear(d, hidden), nn.ELU(), nn.Linear(hidden, hidden // 2), nn.ELU(), nn.Linear(hidden // 2, 1)
            )

        def compute(self, inputs, role=""):
            return self.net(inputs["observations"]), {}

    return Policy(), Value()


def train(
    *,
    out: Path,
    device: str | None,
    num_envs: int,
    task: str,
    timesteps: int,
    image_size: int,
    rollouts: int,
    hidden: int,
    seed: int,
    policy: str = "mlp",
    action_mode: str = "vector",
    channels: tuple[int, ...] = (16, 16),
    log=print,
) -> dict[str, Any]:
    """Train PPO for ``timesteps`` batched steps (each ``num_envs`` env steps); returns the summary.
    ``policy="mlp"``: MLPs on the flattened, standardised observation (``action_mode`` must be
    "vector"); ``"cortical"``: the wrap-around cortical convolution (:func:`_cortical_models`), with
    ``action_mode`` "cell" or "vector". The curve CSV is appended after every rollout as it goes."""
    if policy not in ("mlp", "cortical"):
        raise ValueError(f"policy must be 'mlp' or 'cortical'; got {policy!r}")
    if action_mode not in ("vector", "cell"):
        raise ValueError(f"action_mode must be 'vector' or 'cell'; got {action_mode!r}")
    if policy == "mlp" and action_mode != "vector":
        raise ValueError(
            "the mlp policy is a Gaussian over the vector saccade: use action_mode='vector' "
            "or policy='cortical' for cell actions"
        )
    _require()
    from skrl.agents.torch.ppo import PPO, PPO_CFG
    from skrl.memories.torch import RandomMemory
    from skrl.resources.preprocessors.torch import RunningStandardScaler
    from skrl.trainers.torch import SequentialTrainer
    from skrl.utils import set_seed

    import envs

    set_seed(seed)
    env = envs.BatchedBinocularSaccade(
        num_envs,
        device=device,
        task=task,
        image_size=image_size,
        autoreset_mode="same_step",
        output="torch",
        action_mode=action_mode,
    )
    env.reset(seed=seed)
    wrapped = DeviceVectorWrapper(env)
    dev = wrapped.device
    if policy == "cortical":
        from experiments.agents.extractors import cell_saccade_vectors

        vectors = cell_saccade_vectors(env.grid.points, env.max_amplitude)
        policy_m, value = _cortical_models(
            wrapped.observation_space, wrapped.action_space, dev, env.single_observation_space, vectors, tuple(channels)
        )
        pre = {}  # the convolution reads the intensities in [0, 1] as they are
    else:
        policy_m, value = _models(wrapped.observation_space, wrapped.action_space, dev, hidden)
        pre = {
            "observation_preprocessor": RunningStandardScaler,
            "observation_preprocessor_kwargs": {"size": wrapped.observation_space, "device": dev},
        }
    cfg = PPO_CFG(
        rollouts=rollouts,
        learning_epochs=4,
        mini_batches=max(1, min(4, rollouts * num_envs // 64)),
        learning_rate=3e-4 if policy == "mlp" else 1e-3,
        discount_factor=0.95,
        entropy_loss_scale=0.0 if policy == "mlp" else 0.01,
        **pre,
        value_preprocessor=RunningStandardScaler,
        value_preprocessor_kwargs={"size": 1, "device": dev},
    )
    cfg.experiment.directory = str(out)
    cfg.experiment.experiment_name = "skrl"
    cfg.experiment.write_interval = 0
    cfg.experiment.checkpoint_interval = 0
    memory = RandomMemory(memory_size=rollouts, num_envs=num_envs, device=dev)
    agent = PPO(
        models={"policy": policy_m, "value": value},
        memory=memory,
        observation_space=wrapped.observation_space,
        action_space=wrapped.action_space,
        device=dev,
        cfg=cfg,
    )
    trainer = SequentialTrainer(
        env=wrapped,
        agents=agent,
        cfg={"timesteps": timesteps, "headless": True, "disable_progressbar": True, "close_environment_at_exit": False},
    )
    with open(out / "learning_curve.csv", "w", newline="") as f:
        csv.writer(f).writerow(["env_steps", "episodes", "mean_return", "success_rate"])
    wrapped.curve_path, wrapped.per_rollout = out / "learning_curve.csv", rollouts * num_envs
    t0 = time.perf_counter()
    trainer.train()
    wall = time.perf_counter() - t0
    rows = _curve(wrapped.episodes, rollouts * num_envs, timesteps * num_envs)
    _plot(rows, out / "learning_curve.png", f"PPO (skrl) on {task}, {num_envs} worlds, {env.device}")
    summary = {
        "device": str(env.device),
        "num_envs": num_envs,
        "task": task,
        "policy": policy,
        "action_mode": action_mode,
        "timesteps": timesteps,
        "env_steps": timesteps * num_envs,
        "image_size": image_size,
        "rollouts": rollouts,
        "hidden": hidden,
        "seed": seed,
        "wall_s": round(wall, 1),
        "env_steps_per_s": round(timesteps * num_envs / wall, 1),
        "episodes": len(wrapped.episodes),
    }
    summary["format"] = "skrl-npz-1"
    save_weights(out / "agent.npz", agent, summary)
    write_json(out / "ppo.json", summary)
    env.close()
    for r in rows:
        log(f"  {r[0]:>9} env steps: {r[1]:>5} episodes, return {r[2]:+.3f}, success {r[3]:.2f}")
    return summary


def save_weights(path: Path, agent, summary: dict[str, Any]) -> Path:
    """The agent's checkpoint modules (policy, value, optimizer, preprocessors: their state dicts) as
    data: one ``.npz`` with the run's summary inside (:func:`experiments.agents.saved.write_unit`),
    never ``torch.save``'s pickle."""
    from experiments.agents.saved import pack, write_unit

    arrays: dict = {}
    states = {name: agent._get_internal_value(module) for name, module in agent.checkpoint_modules.items()}
    skeleton = pack(states, "agent", arrays)
    return write_unit(path, arrays, {"summary": summary, "state_dicts": skeleton})


def _curve(episodes, per_rollout: int, total: int, start: int = 0) -> list[tuple[int, int, float, float]]:
    """Per rollout: (env steps at its end, episodes finished in it, their mean return, success rate)."""
    rows = []
    for end in range(start + per_rollout, total + 1, per_rollout):
        eps = [e for e in episodes if end - per_rollout < e[0] <= end]
        if eps:
            rows.append((end, len(eps), float(np.mean([e[1] for e in eps])), float(np.mean([e[2] for e in eps]))))
    return rows


def _plot(rows, path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(9, 3.4))
    if rows:
        x = [r[0] for r in rows]
        ax[0].plot(x, [r[2] for r in rows], "o-")
        ax[1].plot(x, [r[3] for r in rows], "o-")
    ax[0].set(xlabel="env steps", ylabel="mean episode return")
    ax[1].set(xlabel="env steps", ylabel="success rate", ylim=(-0.02, 1.02))
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    save_figure(fig, path, dpi=120)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m experiments.agents.skrl_recipe", description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=out_dir, required=True, help="folder for the curve, the checkpoint and ppo.json")
    ap.add_argument("--device", default=None, help="cuda, cuda:<i> or cpu (default: cuda when available)")
    ap.add_argument("--num-envs", type=int_in(1, 65536), default=8)
    add_task_option(ap)
    add_timesteps_option(ap, "batched steps (each num-envs env steps)", default=48)
    add_image_size_option(ap, "pixels per side of each eye's image", default=64)
    ap.add_argument("--rollouts", type=int_in(1, 4096), default=8, help="batched steps per PPO update")
    ap.add_argument("--hidden", type=int_in(8, 4096), default=256)
    add_seed_option(ap, "seed")
    ap.add_argument(
        "--policy",
        choices=("mlp", "cortical"),
        default="mlp",
        help="mlp: MLPs on the flattened observation; cortical: the wrap-around cortical convolution",
    )
    ap.add_argument(
        "--action-mode",
        choices=("vector", "cell"),
        default="vector",
        help="vector: the Box saccade; cell: a retina cell index (needs --policy cortical)",
    )
    args = ap.parse_args(argv)
    if args.timesteps < args.rollouts:
        ap.error(
            f"--timesteps ({args.timesteps}) must be at least --rollouts ({args.rollouts}): PPO updates once per rollout"
        )
    if args.policy == "mlp" and args.action_mode == "cell":
        ap.error("--action-mode cell needs --policy cortical (the mlp policy is a Gaussian over the vector saccade)")
    args.out.mkdir(parents=True, exist_ok=True)
    s = train(
        out=args.out,
        device=args.device,
        num_envs=args.num_envs,
        task=args.task,
        timesteps=args.timesteps,
        image_size=args.image_size,
        rollouts=args.rollouts,
        hidden=args.hidden,
        seed=args.seed,
        policy=args.policy,
        action_mode=args.action_mode,
    )
    print(
        f"{s['env_steps']} env steps in {s['wall_s']} s ({s['env_steps_per_s']} env-steps/s) on {s['device']}; "
        f"wrote {args.out}/learning_curve.csv, learning_curve.png, agent.npz, ppo.json"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
