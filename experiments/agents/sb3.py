"""Stable-Baselines3 agents that read the retina: PPO (Schulman et al. 2017) and SAC (Haarnoja et al.
2018) with the wrap-around cortical convolution of :mod:`experiments.agents.extractors`.

Policies (``policy`` in the hyper-parameter files, :mod:`experiments.agents.hyperparams`):

- ``cortical-cell`` (:class:`CorticalActorCritic` with ``head="cell"``): the convolution's per-cell
  logit map *is* the action distribution. With ``action_mode="cell"`` it is the categorical over the
  M x N superior-colliculus cells (a fully convolutional motor map); with the continuous ``Box``
  saccade (``action_mode="vector"``) the Gaussian's mean is the map's soft-argmax saccade vector
  (:class:`~experiments.agents.extractors.SoftArgmaxSaccade`). The value reads the pooled features,
  the fovea and the eye-position signal.
- ``cortical-dense``: the same convolution, then SB3's usual MLP heads on the flattened features.
- ``mlp``: SB3's ``MultiInputPolicy`` on the flattened observation (the old recipe's policy).
- ``cortical-sac`` (:class:`CorticalSAC`): SAC's actor mean is the soft-argmax saccade (through
  atanh, as SAC squashes with tanh); its critics read the same convolution's features.

:func:`train_sb3` trains one agent, appending a row to ``training_log.csv`` after every evaluation
on held-out validation episodes (so an interrupted run keeps its curve) and saving the model then.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from gymnasium import spaces
from torch import nn

from ..folders import append_csv_row
from .extractors import CorticalEncoder, SoftArgmaxSaccade, cell_saccade_vectors
from .rollout import episode_seeds, evaluate, make_env

__all__ = ["CURVE_COLUMNS", "VALIDATION_STREAM", "CorticalActorCritic", "CorticalFeatures", "CorticalSAC",
           "SB3Agent", "load_agent", "make_rl_env", "saccade_vectors", "train_sb3"]

VALIDATION_STREAM = 2  # the CEM trainer's validation episodes: neither the training nor the held-out ones
CURVE_COLUMNS = ("env_steps", "elapsed_s", "success_rate", "mean_return", "mean_saccades", "train_episodes",
                 "train_success_rate", "train_return")
OBS_KEYS = ("cortical", "fovea", "eyes")
ALGOS = ("ppo", "sac")
POLICIES = ("cortical-cell", "cortical-dense", "mlp", "cortical-sac")


def make_rl_env(task: str = "fixate", *, action_mode: str = "cell", image_size: int = 96, shaping: bool = False,
                gamma: float = 0.9, shaping_scale_deg: float = 10.0, **env_kwargs: Any):
    """The training env: :func:`~experiments.agents.rollout.make_env`'s env (both eyes' colour
    cortical map) with ``action_mode``, optionally :class:`envs.PotentialShaping` (``gamma``,
    ``shaping_scale_deg``), and Gymnasium's ``FilterObservation`` keeping ``cortical``, ``fovea``
    and ``eyes`` (the policy does not read ``remapped``)."""
    from gymnasium.wrappers import FilterObservation

    import envs

    env = make_env(task, action_mode=action_mode, image_size=image_size, **env_kwargs)
    if shaping:
        env = envs.PotentialShaping(env, gamma=gamma, scale_deg=shaping_scale_deg)
    return FilterObservation(env, list(OBS_KEYS))


def saccade_vectors(env) -> list[list[float]]:
    """The ``Box`` action of each retina cell's centre for ``env`` (:func:`cell_saccade_vectors`)."""
    base = env.unwrapped
    return cell_saccade_vectors(base.vision.grid.points, base.max_amplitude).tolist()


def _sb3():
    from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

    return BaseFeaturesExtractor


class CorticalFeatures(_sb3()):
    """SB3 features extractor: ``[per-cell logits (M*N), global features]`` of a
    :class:`~experiments.agents.extractors.CorticalEncoder` over ``cortical`` (and ``fovea``,
    ``eyes`` when the observation has them). With ``saccade_vectors`` the global part starts with
    the map's soft-argmax saccade (2 numbers), so that a head can compare an action with where the
    map points (SAC's critics: Q(s, a) is then a function of a minus that saccade, which an MLP
    learns quickly, rather than of 336 logits)."""

    def __init__(self, observation_space: spaces.Dict, channels: tuple[int, ...] = (32, 32),
                 logit_gain: float = 1.0, saccade_vectors: list | None = None) -> None:
        if not isinstance(observation_space, spaces.Dict) or "cortical" not in observation_space.spaces:
            raise ValueError("CorticalFeatures needs a Dict observation with a 'cortical' (2, M, N, C) entry")
        sp = observation_space.spaces
        enc = CorticalEncoder(sp["cortical"].shape, sp["fovea"].shape if "fovea" in sp else None,
                              int(np.prod(sp["eyes"].shape)) if "eyes" in sp else 0, tuple(channels),
                              logit_gain=logit_gain)
        super().__init__(observation_space, features_dim=enc.n_cells + enc.global_dim + (0 if saccade_vectors is None else 2))
        self.pointer = None if saccade_vectors is None else SoftArgmaxSaccade(np.asarray(saccade_vectors, np.float32))
        self.encoder = enc
        self.n_cells = enc.n_cells

    def forward(self, observations: dict[str, torch.Tensor]) -> torch.Tensor:
        logits, g = self.encoder(observations)
        parts = [logits] + ([self.pointer(logits)] if self.pointer is not None else []) + [g]
        return torch.cat(parts, dim=1)


class _CellSplit(nn.Module):
    """PPO's 'mlp_extractor' for the cell head: the actor's latent is the logit map, the critic's an
    MLP of the global features."""

    def __init__(self, n_cells: int, global_dim: int, vf_hidden: int) -> None:
        super().__init__()
        self.n_cells, self.latent_dim_pi, self.latent_dim_vf = n_cells, n_cells, vf_hidden
        self.vf = nn.Sequential(nn.Linear(global_dim, vf_hidden), nn.Tanh(), nn.Linear(vf_hidden, vf_hidden), nn.Tanh())

    def forward_actor(self, features: torch.Tensor) -> torch.Tensor:
        return features[:, :self.n_cells]

    def forward_critic(self, features: torch.Tensor) -> torch.Tensor:
        return self.vf(features[:, self.n_cells:])

    def forward(self, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.forward_actor(features), self.forward_critic(features)


class _Slice(nn.Module):
    def __init__(self, start: int, stop: int | None) -> None:
        super().__init__()
        self.start, self.stop = start, stop

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x[:, self.start:self.stop]


def _actor_critic():
    from stable_baselines3.common.policies import ActorCriticPolicy

    return ActorCriticPolicy


class CorticalActorCritic(_actor_critic()):
    """PPO policy over :class:`CorticalFeatures`. ``head="cell"``: actions from the per-cell logit
    map (categorical for ``Discrete`` cells; for ``Box``, a Gaussian whose mean is the soft-argmax of
    ``saccade_vectors``, required then); ``head="dense"``: SB3's MLP heads on all features."""

    def __init__(self, observation_space, action_space, lr_schedule, head: str = "cell",
                 saccade_vectors: list | None = None, vf_hidden: int = 64, channels: tuple[int, ...] = (32, 32),
                 logit_gain: float = 1.0, **kwargs: Any) -> None:
        if head not in ("cell", "dense"):
            raise ValueError(f"head must be 'cell' or 'dense'; got {head!r}")
        if head == "cell" and isinstance(action_space, spaces.Box) and saccade_vectors is None:
            raise ValueError("a cell head on a Box action needs saccade_vectors (experiments.agents.sb3.saccade_vectors(env))")
        self.head, self.vf_hidden = head, int(vf_hidden)
        self.saccade_vectors = saccade_vectors
        kwargs.setdefault("features_extractor_class", CorticalFeatures)
        kwargs.setdefault("features_extractor_kwargs", {"channels": tuple(channels), "logit_gain": logit_gain})
        super().__init__(observation_space, action_space, lr_schedule, **kwargs)

    def _build_mlp_extractor(self) -> None:
        if self.head == "dense":
            return super()._build_mlp_extractor()
        fe = self.features_extractor
        self.mlp_extractor = _CellSplit(fe.n_cells, fe.features_dim - fe.n_cells, self.vf_hidden)

    def _build(self, lr_schedule) -> None:
        super()._build(lr_schedule)
        if self.head == "cell":
            self.action_net = (nn.Identity() if isinstance(self.action_space, spaces.Discrete)
                               else SoftArgmaxSaccade(np.asarray(self.saccade_vectors, np.float32)))
            with torch.no_grad():  # a near-uniform initial policy over cells
                self.features_extractor.encoder.logit.weight.mul_(0.01)
                self.features_extractor.encoder.logit.bias.zero_()
            self.optimizer = self.optimizer_class(self.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs)


def _sac_policy():
    from stable_baselines3.sac.policies import SACPolicy

    return SACPolicy


class CorticalSAC(_sac_policy()):
    """SAC policy over :class:`CorticalFeatures`: the actor's mean is atanh of the soft-argmax
    saccade of the logit map (SAC squashes with tanh), its log-std a linear map of the global
    features starting at ``log_std_init``; the critics are MLPs (``net_arch['qf']``) of the features
    (with ``pointer``, their own map's soft-argmax saccade among them) and the action."""

    def __init__(self, observation_space, action_space, lr_schedule, saccade_vectors: list | None = None,
                 channels: tuple[int, ...] = (32, 32), logit_gain: float = 1.0, pointer: bool = True,
                 log_std_init: float = -1.5, **kwargs: Any) -> None:
        if saccade_vectors is None:
            raise ValueError("CorticalSAC needs saccade_vectors (experiments.agents.sb3.saccade_vectors(env))")
        if not np.isfinite(log_std_init):
            raise ValueError(f"log_std_init must be a finite number; got {log_std_init!r}")
        self.saccade_vectors, self.std_init = saccade_vectors, float(log_std_init)
        kwargs.setdefault("features_extractor_class", CorticalFeatures)
        kwargs.setdefault("features_extractor_kwargs", {"channels": tuple(channels), "logit_gain": logit_gain,
                                                        "saccade_vectors": saccade_vectors if pointer else None})
        kwargs.setdefault("net_arch", {"pi": [], "qf": [256, 256]})
        super().__init__(observation_space, action_space, lr_schedule, **kwargs)

    def make_actor(self, features_extractor=None):
        actor = super().make_actor(features_extractor)
        n = actor.features_extractor.n_cells
        dim = int(np.prod(self.action_space.shape))
        actor.mu = nn.Sequential(_Slice(0, n), SoftArgmaxSaccade(np.asarray(self.saccade_vectors, np.float32), atanh=True))
        actor.log_std = nn.Sequential(_Slice(n, None), nn.Linear(actor.features_dim - n, dim))
        with torch.no_grad():
            actor.features_extractor.encoder.logit.weight.mul_(0.01)
            actor.log_std[1].weight.mul_(0.01)
            actor.log_std[1].bias.fill_(self.std_init)
        return actor.to(self.device)


# ---------------------------------------------------------------------------------------------- agents
class SB3Agent:
    """A saved SB3 model as a policy for :func:`~experiments.agents.rollout.evaluate`: filters the
    observation to the keys the model reads; ``deterministic`` (default) or sampled actions (then
    seeded through :meth:`seed`)."""

    def __init__(self, model, metadata: dict[str, Any], path: Path, deterministic: bool = True) -> None:
        self.model, self.metadata, self.path = model, metadata, Path(path)
        self.deterministic = bool(deterministic)
        self.keys = tuple(model.observation_space.spaces) if isinstance(model.observation_space, spaces.Dict) else None
        self.name = f"{metadata.get('algo', 'ppo')}:{path}"

    def seed(self, seed: int) -> None:
        """Seed the sampling of a stochastic policy (torch's generator)."""
        torch.manual_seed(int(seed))

    def act(self, obs: dict, rng=None):
        if self.keys is not None and isinstance(obs, dict):
            obs = {k: obs[k] for k in self.keys}
        a, _ = self.model.predict(obs, deterministic=self.deterministic)
        return int(a) if isinstance(self.model.action_space, spaces.Discrete) else np.asarray(a, np.float32)


def load_agent(directory: str | Path, deterministic: bool = True) -> SB3Agent:
    """Load a folder written by :func:`train_sb3` (``<algo>.json`` + ``<algo>_<task>.zip``) or by the
    PPO recipe (``ppo.json`` + ``ppo_<task>.zip``). Loading unpickles parts of the zip: trusted files only."""
    import stable_baselines3 as sb3

    d = Path(directory)
    metas = [d / f"{a}.json" for a in ALGOS if (d / f"{a}.json").is_file()]
    if not metas:
        raise FileNotFoundError(f"{d} is not a saved SB3 model: missing ppo.json or sac.json")
    try:
        meta = json.loads(metas[0].read_text())
        task, env_kwargs = meta["task"], dict(meta["env_kwargs"])
    except (json.JSONDecodeError, UnicodeDecodeError, KeyError, TypeError, ValueError) as err:
        raise ValueError(f"{metas[0]} is not a valid {metas[0].stem.upper()} metadata file ({err}); retrain") from None
    algo = meta.get("algo", metas[0].stem)
    if algo not in ALGOS:
        raise ValueError(f"{metas[0]}: unknown algo {algo!r}; expected one of {', '.join(ALGOS)}")
    zip_path = d / f"{algo}_{task}.zip"
    if not zip_path.is_file():
        raise FileNotFoundError(f"{d} is not a saved SB3 model: missing {zip_path.name}")
    cls = sb3.PPO if algo == "ppo" else sb3.SAC
    try:
        model = cls.load(zip_path, device="cpu")
    except Exception as err:  # zipfile/pickle/torch errors of many kinds for a corrupt file
        raise ValueError(f"{zip_path} could not be loaded by stable-baselines3 ({type(err).__name__}: {err}); "
                         "retrain") from None
    return SB3Agent(model, {**meta, "task": task, "env_kwargs": env_kwargs, "algo": algo}, d, deterministic)


# ---------------------------------------------------------------------------------------------- training
def _callback(eval_env, agent_meta: dict, out: Path, algo: str, task: str, eval_freq: int, eval_seeds: np.ndarray,
              seed: int, log):
    from stable_baselines3.common.callbacks import BaseCallback

    class Curve(BaseCallback):
        """Every ``eval_freq`` env steps: evaluate the deterministic policy on the validation
        episodes, append a row to training_log.csv, save the model."""

        def _on_training_start(self) -> None:
            self.t0 = time.perf_counter()
            self.eval_s = 0.0
            self.next_eval = 0
            self.train: list[tuple[float, bool]] = []
            self.ret = None
            self._evaluate()

        def _evaluate(self) -> None:
            t = time.perf_counter()
            self.model.save(out / f"{algo}_{task}.zip")
            pol = SB3Agent(self.model, agent_meta, out)
            ev = evaluate(eval_env, pol, eval_seeds, rng_seed=seed)
            self.eval_s += time.perf_counter() - t
            k = len(self.train)
            row = {"env_steps": self.num_timesteps, "elapsed_s": round(time.perf_counter() - self.t0, 2),
                   "success_rate": ev.success_rate, "mean_return": round(ev.mean_reward, 5),
                   "mean_saccades": ev.mean_saccades, "train_episodes": k,
                   "train_success_rate": round(sum(s for _, s in self.train) / k, 4) if k else "",
                   "train_return": round(sum(r for r, _ in self.train) / k, 5) if k else ""}
            append_csv_row(out / "training_log.csv", CURVE_COLUMNS, row)
            log(f"{algo} {task}: {row['env_steps']} steps, {row['elapsed_s']:.0f} s: validation success "
                f"{ev.success_rate:.2f}, return {ev.mean_reward:+.3f}; training episodes {k}")
            self.train = []
            self.next_eval += eval_freq

        def _on_step(self) -> bool:
            rewards, dones, infos = self.locals["rewards"], self.locals["dones"], self.locals["infos"]
            if self.ret is None:
                self.ret = np.zeros(len(dones))
            for i, (r, d, info) in enumerate(zip(rewards, dones, infos)):
                self.ret[i] += float(info.get("reward_task", r))  # the task's reward, without shaping
                if d:
                    self.train.append((self.ret[i], bool(info.get("success", False))))
                    self.ret[i] = 0.0
            if self.num_timesteps >= self.next_eval:
                self._evaluate()
            return True

    return Curve()


def _one_torch_thread() -> None:
    """One torch thread for the whole run. numba's parallel kernels (the env's) start their OpenMP
    threading layer on first use, and that start resets the process's OpenMP thread count, torch's
    included: started after ``torch.set_num_threads(1)``, torch ran on 2 threads from the first env
    step on, and the trained weights depended on whether anything had run numba's kernels before
    (the cell-action policy on ``search``). So numba's layer is started first."""
    import numba

    numba.get_num_threads()  # launches numba's threading layer now
    torch.set_num_threads(1)


def train_sb3(out: str | Path, algo: str, task: str, hyperparams: dict[str, Any], seed: int = 0,
              timesteps: int | None = None, log=print) -> dict[str, Any]:
    """Train ``algo`` ("ppo" or "sac") on ``task`` with ``hyperparams`` (one entry of a file in
    ``experiments/hyperparams/``, see :func:`experiments.agents.hyperparams.load_hyperparams`);
    writes ``training_log.csv`` (appended at every evaluation), ``<algo>_<task>.zip`` and
    ``<algo>.json`` into ``out``. Deterministic under ``seed`` (one torch thread). Returns the metadata."""
    import stable_baselines3 as sb3
    from stable_baselines3.common.vec_env import DummyVecEnv

    if algo not in ALGOS:
        raise ValueError(f"algo must be one of {', '.join(ALGOS)}; got {algo!r}")
    hp = json.loads(json.dumps(hyperparams))  # a deep copy
    total = int(timesteps if timesteps is not None else hp.pop("n_timesteps", 10_000))
    hp.pop("n_timesteps", None)
    if total < 1:
        raise ValueError(f"timesteps must be >= 1; got {total}")
    policy = hp.pop("policy", "cortical-cell")
    if policy not in POLICIES:
        raise ValueError(f"policy must be one of {', '.join(POLICIES)}; got {policy!r}")
    env_kwargs = {"action_mode": "cell", "image_size": 96, **hp.pop("env_kwargs", {})}
    shaping = dict(hp.pop("shaping", {}) or {})
    n_envs = int(hp.pop("n_envs", 1))
    eval_freq = int(hp.pop("eval_freq", 1000))
    eval_episodes = int(hp.pop("eval_episodes", 20))
    policy_kwargs = dict(hp.pop("policy_kwargs", {}) or {})
    if eval_freq < 1 or eval_episodes < 1 or n_envs < 1:
        raise ValueError("n_envs, eval_freq and eval_episodes must be >= 1")
    gamma = float(hp.get("gamma", 0.99))
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    for stale in ("training_log.csv",):
        (out / stale).unlink(missing_ok=True)
    _one_torch_thread()
    torch.manual_seed(seed)

    def factory(rank: int):
        def _make():
            return make_rl_env(task, gamma=gamma, shaping=bool(shaping.get("enabled", False)),
                               shaping_scale_deg=float(shaping.get("scale_deg", 10.0)), **env_kwargs)
        return _make

    venv = DummyVecEnv([factory(i) for i in range(n_envs)])
    venv.seed(seed)
    eval_env = make_env(task, **env_kwargs)
    try:
        vectors = saccade_vectors(venv.envs[0])
        if policy == "mlp":
            policy_cls = "MultiInputPolicy"
        elif algo == "sac":
            if policy != "cortical-sac":
                raise ValueError(f"SAC takes policy 'cortical-sac' or 'mlp'; got {policy!r}")
            policy_cls, policy_kwargs = CorticalSAC, {"saccade_vectors": vectors, **policy_kwargs}
        else:
            if policy == "cortical-sac":
                raise ValueError("policy 'cortical-sac' is SAC's; PPO takes 'cortical-cell', 'cortical-dense' or 'mlp'")
            head = policy.split("-")[1]
            policy_cls = CorticalActorCritic
            policy_kwargs = {"head": head, **({"saccade_vectors": vectors} if head == "cell" else {}), **policy_kwargs}
        cls = sb3.PPO if algo == "ppo" else sb3.SAC
        model = cls(policy_cls, venv, seed=seed, device="cpu", verbose=0, policy_kwargs=policy_kwargs or None, **hp)
        meta = {"algo": algo, "task": task, "policy": policy, "env_kwargs": {**env_kwargs, "cortex": "eyes"},
                "shaping": shaping, "seed": seed, "n_envs": n_envs, "total_timesteps": total, "hyperparams": hyperparams,
                "sb3_version": sb3.__version__, "torch_version": torch.__version__}
        eval_seeds = episode_seeds(seed, eval_episodes, VALIDATION_STREAM)
        cb = _callback(eval_env, meta, out, algo, task, eval_freq, eval_seeds, seed, log)
        t0 = time.perf_counter()
        model.learn(total_timesteps=total, callback=cb, progress_bar=False)
        if cb.num_timesteps != cb.next_eval - eval_freq:  # the last evaluation, at the end
            cb._evaluate()
        wall = time.perf_counter() - t0
        model.save(out / f"{algo}_{task}.zip")
        meta.update(wall_s=round(wall, 1), eval_s=round(cb.eval_s, 1),
                    train_steps_per_s=round(model.num_timesteps / max(1e-9, wall - cb.eval_s), 1))
        (out / f"{algo}.json").write_text(json.dumps(meta, indent=2) + "\n")
        return meta
    finally:
        venv.close()
        eval_env.close()
