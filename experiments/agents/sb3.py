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
on held-out validation episodes and replacing ``checkpoint.npz`` then (a kill -9 loses at most one
evaluation interval; the same command resumes it to the same weights). Models are saved as data
(:func:`save_agent`: ``<algo>.npz`` weights and ``<algo>.json``) and rebuilt from it
(:func:`load_agent`); a Stable-Baselines3 zip, which unpickles code, is never read.
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

from ..folders import append_csv_row, write_csv, write_json
from .extractors import CorticalEncoder, SoftArgmaxSaccade, cell_saccade_vectors
from .rollout import OBS_KEYS, VALIDATION_STREAM, episode_seeds, evaluate, make_env
from .runfolder import CHECKPOINT, SETTINGS, check_settings
from .saved import (
    check_weights_sha256,
    file_sha256,
    pack,
    read_unit,
    rng_state,
    set_rng_state,
    space_from_json,
    space_to_json,
    unpack,
    write_unit,
)

__all__ = [
    "CURVE_COLUMNS",
    "VALIDATION_STREAM",
    "CorticalActorCritic",
    "CorticalFeatures",
    "CorticalSAC",
    "SB3Agent",
    "ShiftReplayBuffer",
    "architecture",
    "finished_meta",
    "load_agent",
    "make_rl_env",
    "plan_run",
    "read_agent_meta",
    "saccade_vectors",
    "save_agent",
    "train_sb3",
]

CURVE_COLUMNS = (
    "env_steps",
    "elapsed_s",
    "success_rate",
    "mean_return",
    "mean_saccades",
    "train_episodes",
    "train_success_rate",
    "train_return",
)
ALGOS = ("ppo", "sac")
POLICIES = ("cortical-cell", "cortical-dense", "mlp", "cortical-sac")


def make_rl_env(
    task: str = "fixate",
    *,
    action_mode: str = "cell",
    image_size: int = 96,
    shaping: bool = False,
    gamma: float = 0.9,
    shaping_scale_deg: float = 10.0,
    **env_kwargs: Any,
):
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


def _shape(entries: dict[str, spaces.Space], key: str) -> tuple[int, ...]:
    """The shape of observation entry ``key`` (a ``Box``: the env's entries all have one)."""
    shape = entries[key].shape
    if shape is None:
        raise ValueError(f"the observation's {key!r} entry must be a Box with a shape; got {entries[key]}")
    return shape


def _sb3():
    from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

    return BaseFeaturesExtractor


_FeaturesBase: Any = _sb3()  # SB3's bases are Any here (a call is no static base), as are those below


class CorticalFeatures(_FeaturesBase):
    """SB3 features extractor: ``[per-cell logits (M*N), global features]`` of a
    :class:`~experiments.agents.extractors.CorticalEncoder` over ``cortical`` (and ``fovea``,
    ``eyes`` when the observation has them). With ``saccade_vectors`` the global part starts with
    the map's soft-argmax saccade (2 numbers), so that a head can compare an action with where the
    map points (SAC's critics: Q(s, a) is then a function of a minus that saccade, which an MLP
    learns quickly, rather than of 336 logits)."""

    def __init__(
        self,
        observation_space: spaces.Dict,
        channels: tuple[int, ...] = (32, 32),
        logit_gain: float = 1.0,
        saccade_vectors: list | None = None,
    ) -> None:
        if not isinstance(observation_space, spaces.Dict) or "cortical" not in observation_space.spaces:
            raise ValueError("CorticalFeatures needs a Dict observation with a 'cortical' (2, M, N, C) entry")
        sp = observation_space.spaces
        enc = CorticalEncoder(
            _shape(sp, "cortical"),
            _shape(sp, "fovea") if "fovea" in sp else None,
            int(np.prod(_shape(sp, "eyes"))) if "eyes" in sp else 0,
            tuple(channels),
            logit_gain=logit_gain,
        )
        super().__init__(
            observation_space, features_dim=enc.n_cells + enc.global_dim + (0 if saccade_vectors is None else 2)
        )
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
        return features[:, : self.n_cells]

    def forward_critic(self, features: torch.Tensor) -> torch.Tensor:
        return self.vf(features[:, self.n_cells :])

    def forward(self, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.forward_actor(features), self.forward_critic(features)


class _Slice(nn.Module):
    def __init__(self, start: int, stop: int | None) -> None:
        super().__init__()
        self.start, self.stop = start, stop

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x[:, self.start : self.stop]


def _actor_critic():
    from stable_baselines3.common.policies import ActorCriticPolicy

    return ActorCriticPolicy


_ActorCriticBase: Any = _actor_critic()


class CorticalActorCritic(_ActorCriticBase):
    """PPO policy over :class:`CorticalFeatures`. ``head="cell"``: actions from the per-cell logit
    map (categorical for ``Discrete`` cells; for ``Box``, a Gaussian whose mean is the soft-argmax of
    ``saccade_vectors``, required then); ``head="dense"``: SB3's MLP heads on all features."""

    def __init__(
        self,
        observation_space,
        action_space,
        lr_schedule,
        head: str = "cell",
        saccade_vectors: list | None = None,
        vf_hidden: int = 64,
        channels: tuple[int, ...] = (32, 32),
        logit_gain: float = 1.0,
        **kwargs: Any,
    ) -> None:
        if head not in ("cell", "dense"):
            raise ValueError(f"head must be 'cell' or 'dense'; got {head!r}")
        if head == "cell" and isinstance(action_space, spaces.Box) and saccade_vectors is None:
            raise ValueError(
                "a cell head on a Box action needs saccade_vectors (experiments.agents.sb3.saccade_vectors(env))"
            )
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
            self.action_net = (
                nn.Identity()
                if isinstance(self.action_space, spaces.Discrete)
                else SoftArgmaxSaccade(np.asarray(self.saccade_vectors, np.float32))
            )
            with torch.no_grad():  # a near-uniform initial policy over cells
                self.features_extractor.encoder.logit.weight.mul_(0.01)
                self.features_extractor.encoder.logit.bias.zero_()
            self.optimizer = self.optimizer_class(self.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs)


def _dict_buffer():
    from stable_baselines3.common.buffers import DictReplayBuffer

    return DictReplayBuffer


def _sac_policy():
    from stable_baselines3.sac.policies import SACPolicy

    return SACPolicy


_SACPolicyBase: Any = _sac_policy()


class CorticalSAC(_SACPolicyBase):
    """SAC policy over :class:`CorticalFeatures`: the actor's mean is atanh of the soft-argmax
    saccade of the logit map (SAC squashes with tanh), its log-std a linear map of the global
    features starting at ``log_std_init``; the critics are MLPs (``net_arch['qf']``) of the features
    (with ``pointer``, their own map's soft-argmax saccade among them) and the action.

    ``critic_encoder=True`` (DrQ, Kostrikov et al. 2021; SAC-AE, Yarats et al. 2021): one encoder,
    the critic's, trained by the critic's loss only; the actor reads its feature map and global
    features detached (:class:`_DetachedCellActor`: its own 1 x 1 logit convolution, soft-argmax
    saccade and log-std layer), so the actor's loss never moves the encoder. The target critic keeps
    its own Polyak-averaged copy of the encoder."""

    def __init__(
        self,
        observation_space,
        action_space,
        lr_schedule,
        saccade_vectors: list | None = None,
        channels: tuple[int, ...] = (32, 32),
        logit_gain: float = 1.0,
        pointer: bool = True,
        log_std_init: float = -1.5,
        critic_encoder: bool = False,
        **kwargs: Any,
    ) -> None:
        if not isinstance(critic_encoder, bool):
            raise ValueError(f"critic_encoder must be true or false; got {critic_encoder!r}")
        self.critic_encoder = critic_encoder
        if saccade_vectors is None:
            raise ValueError("CorticalSAC needs saccade_vectors (experiments.agents.sb3.saccade_vectors(env))")
        if not np.isfinite(log_std_init):
            raise ValueError(f"log_std_init must be a finite number; got {log_std_init!r}")
        self.saccade_vectors, self.std_init = saccade_vectors, float(log_std_init)
        kwargs.setdefault("features_extractor_class", CorticalFeatures)
        kwargs.setdefault(
            "features_extractor_kwargs",
            {
                "channels": tuple(channels),
                "logit_gain": logit_gain,
                "saccade_vectors": saccade_vectors if pointer else None,
            },
        )
        kwargs.setdefault("net_arch", {"pi": [], "qf": [256, 256]})
        super().__init__(observation_space, action_space, lr_schedule, **kwargs)

    def _build(self, lr_schedule) -> None:
        if not self.critic_encoder:
            return super()._build(lr_schedule)
        self.critic = self.make_critic(features_extractor=None)  # its encoder computes with gradients
        self.actor = self.make_actor(features_extractor=self.critic.features_extractor)
        self.actor.optimizer = self.optimizer_class(
            [p for n, p in self.actor.named_parameters() if not n.startswith("features_extractor.")],
            lr=lr_schedule(1),
            **self.optimizer_kwargs,
        )
        self.critic_target = self.make_critic(features_extractor=None)
        self.critic_target.load_state_dict(self.critic.state_dict())
        self.critic.optimizer = self.optimizer_class(
            self.critic.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs
        )
        self.critic_target.set_training_mode(False)

    def make_actor(self, features_extractor=None):
        if self.critic_encoder:
            kwargs = self._update_features_extractor(self.actor_kwargs, features_extractor)
            actor = _DetachedCellActor(
                **{**kwargs, "log_std_init": self.std_init}, saccade_vectors=self.saccade_vectors
            )
            return actor.to(self.device)
        actor = super().make_actor(features_extractor)
        n = actor.features_extractor.n_cells
        dim = int(np.prod(self.action_space.shape))
        actor.mu = nn.Sequential(
            _Slice(0, n), SoftArgmaxSaccade(np.asarray(self.saccade_vectors, np.float32), atanh=True)
        )
        actor.log_std = nn.Sequential(_Slice(n, None), nn.Linear(actor.features_dim - n, dim))
        with torch.no_grad():
            actor.features_extractor.encoder.logit.weight.mul_(0.01)
            actor.log_std[1].weight.mul_(0.01)
            actor.log_std[1].bias.fill_(self.std_init)
        return actor.to(self.device)


def _sac_actor():
    from stable_baselines3.sac.policies import Actor

    return Actor


_SACActorBase: Any = _sac_actor()


class _DetachedCellActor(_SACActorBase):
    """SAC's actor on an encoder it does not train (:class:`CorticalSAC` with ``critic_encoder``):
    its own 1 x 1 convolution of the encoder's *detached* feature map gives the cell-logit map
    (times the encoder's ``logit_gain``), whose soft-argmax saccade (through atanh) is the mean; a
    linear map of the detached global features is the log-std, starting at ``log_std_init``."""

    def __init__(self, *args: Any, saccade_vectors: list, log_std_init: float = -1.5, **kwargs: Any) -> None:
        super().__init__(*args, log_std_init=log_std_init, **kwargs)
        enc = self.features_extractor.encoder
        dim = int(np.prod(self.action_space.shape))
        self.mu = nn.Conv2d(enc.logit.in_channels, 1, 1)
        self.saccade = SoftArgmaxSaccade(np.asarray(saccade_vectors, np.float32), atanh=True)
        self.log_std = nn.Linear(enc.global_dim, dim)
        with torch.no_grad():  # a near-uniform initial map, the given initial log-std
            self.mu.weight.mul_(0.01)
            self.log_std.weight.mul_(0.01)
            self.log_std.bias.fill_(float(log_std_init))

    def get_action_dist_params(self, obs):
        from stable_baselines3.common.preprocessing import preprocess_obs
        from stable_baselines3.sac.policies import LOG_STD_MAX, LOG_STD_MIN

        enc = self.features_extractor.encoder
        h, _, g = enc.encode(preprocess_obs(obs, self.observation_space, normalize_images=self.normalize_images))
        h, g = h.detach(), g.detach()
        mean = self.saccade(enc.logit_gain * self.mu(h).flatten(1))
        return mean, torch.clamp(self.log_std(g), LOG_STD_MIN, LOG_STD_MAX), {}


_DictReplayBufferBase: Any = _dict_buffer()


class ShiftReplayBuffer(_DictReplayBufferBase):
    """SB3's ``DictReplayBuffer`` whose samples' ``cortical`` maps (observation and next observation,
    independently) are shifted by :func:`~experiments.agents.augment.random_shifts` of up to ``pad``
    cells (DrQ's augmentation, K = M = 1; the stored data stay as collected)."""

    def __init__(self, *args: Any, pad: int = 1, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        if isinstance(pad, bool) or not isinstance(pad, int) or pad < 1:
            raise ValueError(f"augment pad must be a whole number of cells >= 1; got {pad!r}")
        self.pad = pad

    def _get_samples(self, batch_inds, env=None):
        from .augment import random_shifts

        s = super()._get_samples(batch_inds, env)
        obs = {**s.observations, "cortical": random_shifts(s.observations["cortical"], self.pad)}
        nxt = {**s.next_observations, "cortical": random_shifts(s.next_observations["cortical"], self.pad)}
        return s._replace(observations=obs, next_observations=nxt)


# ---------------------------------------------------------------------------------------------- agents
class SB3Agent:
    """A saved SB3 policy as a policy for :func:`~experiments.agents.rollout.evaluate`: filters the
    observation to the keys the policy reads; ``deterministic`` (default) or sampled actions (then
    seeded through :meth:`seed`). ``model`` is anything with SB3's ``predict`` and spaces: a trained
    algorithm or a policy rebuilt by :func:`load_agent`."""

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


#: The policy classes a saved model may name (nothing else is ever built from a folder).
POLICY_CLASSES = ("CorticalActorCritic", "CorticalSAC", "MultiInputPolicy")
FORMAT = "sb3-npz-1"


def _policy_class(algo: str, name: str):
    import stable_baselines3 as sb3

    if name == "CorticalActorCritic" and algo == "ppo":
        return CorticalActorCritic
    if name == "CorticalSAC" and algo == "sac":
        return CorticalSAC
    if name == "MultiInputPolicy":
        return (sb3.PPO if algo == "ppo" else sb3.SAC).policy_aliases["MultiInputPolicy"]
    raise ValueError(f"unknown {algo} policy class {name!r}; expected one of {', '.join(POLICY_CLASSES)}")


def architecture(model, algo: str) -> dict[str, Any]:
    """What rebuilds ``model``'s policy without its pickle: the policy class's name, the keyword
    arguments SB3 built it with, and the spaces."""
    name = type(model.policy).__name__
    if name in ("MultiInputActorCriticPolicy", "MultiInputPolicy"):
        name = "MultiInputPolicy"
    kwargs = dict(model.policy_kwargs or {})
    if algo == "ppo":
        kwargs["use_sde"] = bool(model.use_sde)
    if "features_extractor_class" in kwargs or "optimizer_class" in kwargs or "activation_fn" in kwargs:
        raise ValueError(
            "policy_kwargs naming classes (features_extractor_class, optimizer_class, activation_fn) "
            "cannot be saved as data; use the policy names of the hyper-parameter files"
        )
    kwargs = json.loads(json.dumps(kwargs))
    return {
        "policy_class": name,
        "policy_kwargs": kwargs,
        "observation_space": space_to_json(model.observation_space),
        "action_space": space_to_json(model.action_space),
    }


def save_agent(out: Path, model, algo: str, meta: dict[str, Any]) -> dict[str, Any]:
    """Write ``<algo>.npz`` (the policy's weights, with ``meta`` and the :func:`architecture` inside
    the same file) and then ``<algo>.json`` (the same metadata and the weights' SHA-256), each
    atomically; returns the JSON."""
    arrays: dict[str, np.ndarray] = {}
    skeleton = pack(model.policy.state_dict(), "policy", arrays)
    meta = {
        **meta,
        "format": FORMAT,
        "algo": algo,
        "architecture": architecture(model, algo),
        "versions": {
            "stable_baselines3": __import__("stable_baselines3").__version__,
            "torch": torch.__version__,
            "numpy": np.__version__,
        },
    }
    write_unit(out / f"{algo}.npz", arrays, {**meta, "state_dict": skeleton})
    meta["weights_sha256"] = file_sha256(out / f"{algo}.npz")
    write_json(out / f"{algo}.json", meta)
    return meta


def read_agent_meta(directory: str | Path) -> tuple[str, dict[str, Any]]:
    """The algo and the JSON of a folder's saved SB3 policy (``ppo.json`` or ``sac.json``)."""
    d = Path(directory)
    metas = [d / f"{a}.json" for a in ALGOS if (d / f"{a}.json").is_file()]
    if not metas:
        raise FileNotFoundError(f"{d} is not a saved SB3 model: missing ppo.json or sac.json")
    if len(metas) > 1:
        raise ValueError(f"{d} holds both ppo.json and sac.json: not one training run's folder")
    try:
        meta = json.loads(metas[0].read_text(encoding="utf-8"))
        if not isinstance(meta, dict):
            raise TypeError("not a JSON object")
        meta["task"], meta["env_kwargs"] = str(meta["task"]), dict(meta["env_kwargs"])
    except (OSError, UnicodeDecodeError, KeyError, TypeError, ValueError) as err:
        raise ValueError(
            f"{metas[0]} is not a valid {metas[0].stem.upper()} metadata file "
            f"({type(err).__name__}: {str(err)[:80]}); retrain"
        ) from None
    algo = metas[0].stem
    if meta.get("algo", algo) != algo:
        raise ValueError(f"{metas[0]} says algo {meta.get('algo')!r}; retrain")
    if meta.get("format") == "skrl-npz-1":
        raise ValueError(
            f"{d} is a run of the batched engine's skrl recipe: evaluate loads the folders of "
            "'train' and of the SB3 recipe"
        )
    if meta.get("format") != FORMAT:
        raise ValueError(
            f"{metas[0]} is not a {FORMAT!r} model (format {meta.get('format')!r}; models saved as "
            "Stable-Baselines3 zips are never loaded, they run code): retrain with this version"
        )
    return algo, meta


def load_agent(directory: str | Path, deterministic: bool = True) -> SB3Agent:
    """Load a folder written by :func:`train_sb3` or by the PPO recipe: the policy is rebuilt from
    the JSON architecture and the weights read from ``<algo>.npz`` (``allow_pickle=False``); no
    pickle, zip or ``torch.load`` is ever read."""
    d = Path(directory)
    algo, meta = read_agent_meta(d)
    wpath = d / f"{algo}.npz"
    if not wpath.is_file():
        raise FileNotFoundError(f"{d} is not a saved SB3 model: missing {wpath.name}")
    check_weights_sha256(wpath, meta.get("weights_sha256"), f"{algo}.json")
    arrays, inner = read_unit(wpath)
    try:
        arch = inner["architecture"]
        cls = _policy_class(algo, arch["policy_class"])
        obs_space, act_space = space_from_json(arch["observation_space"]), space_from_json(arch["action_space"])
        policy = cls(obs_space, act_space, lambda _: 1e-3, **dict(arch["policy_kwargs"]))
        policy.load_state_dict(unpack(inner["state_dict"], arrays, tensors=True), strict=True)
    except (KeyError, TypeError, ValueError, RuntimeError) as err:
        raise ValueError(
            f"{wpath}: the saved policy cannot be rebuilt ({type(err).__name__}: "
            f"{str(err).splitlines()[0][:160]}); retrain"
        ) from None
    policy.set_training_mode(False)
    return SB3Agent(policy, {**meta, "algo": algo}, d, deterministic)


# ---------------------------------------------------------------------------------------------- training
def _callback():
    from stable_baselines3.common.callbacks import BaseCallback

    class TrainEpisodes(BaseCallback):
        """The training episodes' task return and success (the env is reset at each chunk's start)."""

        def _on_training_start(self) -> None:
            self.ret: np.ndarray | None = None
            if not hasattr(self, "train"):
                self.train: list[tuple[float, bool]] = []

        def _on_step(self) -> bool:
            rewards, dones, infos = self.locals["rewards"], self.locals["dones"], self.locals["infos"]
            if self.ret is None:
                self.ret = np.zeros(len(dones))
            for i, (r, d, info) in enumerate(zip(rewards, dones, infos)):
                self.ret[i] += float(info.get("reward_task", r))  # the task's reward, without shaping
                if d:
                    self.train.append((self.ret[i], bool(info.get("success", False))))
                    self.ret[i] = 0.0
            return True

    return TrainEpisodes()


def _one_torch_thread() -> None:
    """One torch thread for the whole run. numba's parallel kernels (the env's) start their OpenMP
    threading layer on first use, and that start resets the process's OpenMP thread count, torch's
    included: started after ``torch.set_num_threads(1)``, torch ran on 2 threads from the first env
    step on, and the trained weights depended on whether anything had run numba's kernels before
    (the cell-action policy on ``search``). So numba's layer is started first."""
    import numba

    numba.get_num_threads()  # launches numba's threading layer now
    torch.set_num_threads(1)


def plan_run(
    algo: str, task: str, hyperparams: dict[str, Any], seed: int = 0, timesteps: int | None = None
) -> dict[str, Any]:
    """The settings of one run (``train.json``): ``hyperparams`` split into the env's, the shaping,
    the policy's, the evaluation's and the algorithm's own; ``ValueError`` for bad ones."""
    if algo not in ALGOS:
        raise ValueError(f"algo must be one of {', '.join(ALGOS)}; got {algo!r}")
    hp = json.loads(json.dumps(hyperparams))  # a deep copy
    total = int(timesteps if timesteps is not None else hp.get("n_timesteps", 10_000))
    hp.pop("n_timesteps", None)
    if total < 1:
        raise ValueError(f"timesteps must be >= 1; got {total}")
    policy = hp.pop("policy", "cortical-cell")
    if policy not in POLICIES:
        raise ValueError(f"policy must be one of {', '.join(POLICIES)}; got {policy!r}")
    if algo == "sac" and policy not in ("cortical-sac", "mlp"):
        raise ValueError(f"SAC takes policy 'cortical-sac' or 'mlp'; got {policy!r}")
    if algo == "ppo" and policy == "cortical-sac":
        raise ValueError("policy 'cortical-sac' is SAC's; PPO takes 'cortical-cell', 'cortical-dense' or 'mlp'")
    plan = {
        "format": FORMAT,
        "algo": algo,
        "task": task,
        "seed": int(seed),
        "policy": policy,
        "env_kwargs": {"action_mode": "cell", "image_size": 96, **hp.pop("env_kwargs", {})},
        "shaping": dict(hp.pop("shaping", {}) or {}),
        "n_envs": int(hp.pop("n_envs", 1)),
        "eval_freq": int(hp.pop("eval_freq", 1000)),
        "eval_episodes": int(hp.pop("eval_episodes", 20)),
        "policy_kwargs": dict(hp.pop("policy_kwargs", {}) or {}),
        "total_timesteps": total,
    }
    if plan["eval_freq"] < 1 or plan["eval_episodes"] < 1 or plan["n_envs"] < 1:
        raise ValueError("n_envs, eval_freq and eval_episodes must be >= 1")
    augment = hp.pop("augment", None)
    if augment is not None:  # DrQ's shifts (ShiftReplayBuffer); absent from the plans of runs without them
        if algo != "sac" or policy != "cortical-sac":
            raise ValueError("augment (DrQ shifts of the replay samples) applies to SAC with policy 'cortical-sac'")
        pad = augment.get("pad") if isinstance(augment, dict) and set(augment) == {"pad"} else None
        if isinstance(pad, bool) or not isinstance(pad, int) or pad < 1:
            raise ValueError(f"augment must be {{pad: N}} with N >= 1 whole cells; got {augment!r}")
        plan["augment"] = {"pad": pad}
    plan["algo_kwargs"] = hp
    plan["hyperparams"] = json.loads(json.dumps(hyperparams))
    return plan


def _make_model(plan: dict[str, Any], venv):
    import stable_baselines3 as sb3

    vectors = saccade_vectors(venv.envs[0])
    policy, pk = plan["policy"], dict(plan["policy_kwargs"])
    policy_cls: str | type
    if policy == "mlp":
        policy_cls = "MultiInputPolicy"
    elif plan["algo"] == "sac":
        policy_cls, pk = CorticalSAC, {"saccade_vectors": vectors, **pk}
    else:
        head = policy.split("-")[1]
        policy_cls = CorticalActorCritic
        pk = {"head": head, **({"saccade_vectors": vectors} if head == "cell" else {}), **pk}
    cls = sb3.PPO if plan["algo"] == "ppo" else sb3.SAC
    kwargs = dict(plan["algo_kwargs"])
    if "augment" in plan:
        kwargs.update(replay_buffer_class=ShiftReplayBuffer, replay_buffer_kwargs={"pad": plan["augment"]["pad"]})
    model = cls(policy_cls, venv, seed=plan["seed"], device="cpu", verbose=0, policy_kwargs=pk or None, **kwargs)
    model.set_logger(silent_logger())
    return model


def silent_logger():
    """An SB3 logger with no output: SB3's default at ``verbose=0`` makes a ``/tmp/SB3-<date>`` folder
    on every ``learn()`` call and leaves it behind; the training curve is this project's own CSV."""
    from stable_baselines3.common.logger import Logger

    return Logger(folder=None, output_formats=[])


def _capture(model) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Everything a resumed run needs beyond the settings: weights and optimizers, SAC's entropy
    coefficient and replay buffer, counters, and every random-number generator the training reads."""
    arrays: dict[str, np.ndarray] = {}
    state: dict[str, Any] = {
        "params": pack(model.get_parameters(), "params", arrays),
        "num_timesteps": int(model.num_timesteps),
        "n_updates": int(model._n_updates),
        "episode_num": int(model._episode_num),
        "action_space_rng": model.action_space.np_random.bit_generator.state,
        "rng": rng_state(arrays),
    }
    if getattr(model, "ent_coef_optimizer", None) is not None:
        state["log_ent_coef"] = pack(model.log_ent_coef, "log_ent_coef", arrays)
    rb = getattr(model, "replay_buffer", None)
    if rb is not None:
        n = rb.buffer_size if rb.full else rb.pos
        parts = {"actions": rb.actions, "rewards": rb.rewards, "dones": rb.dones, "timeouts": rb.timeouts}
        if isinstance(rb.observations, dict):
            parts.update({f"obs/{k}": v for k, v in rb.observations.items()})
            parts.update({f"next_obs/{k}": v for k, v in rb.next_observations.items()})
        else:
            parts.update({"obs": rb.observations, "next_obs": rb.next_observations})
        for k, v in parts.items():
            arrays[f"buffer/{k}"] = v[:n]
        state["buffer"] = {"pos": int(rb.pos), "full": bool(rb.full), "n": int(n), "parts": sorted(parts)}
    return arrays, state


def _restore(model, arrays: dict[str, np.ndarray], state: dict[str, Any]) -> None:
    """The inverse of :func:`_capture` on a model built from the same settings."""
    try:
        model.set_parameters(unpack(state["params"], arrays, tensors=True), exact_match=True, device="cpu")
        if "log_ent_coef" in state:
            with torch.no_grad():
                model.log_ent_coef.copy_(unpack(state["log_ent_coef"], arrays, tensors=True))
        model.num_timesteps, model._n_updates = int(state["num_timesteps"]), int(state["n_updates"])
        model._episode_num = int(state["episode_num"])
        model.action_space.np_random.bit_generator.state = state["action_space_rng"]
        if "buffer" in state:
            rb, b = model.replay_buffer, state["buffer"]
            n = int(b["n"])
            for k in b["parts"]:
                if k.startswith(("obs/", "next_obs/")):
                    head, key = k.split("/", 1)
                    target = (rb.observations if head == "obs" else rb.next_observations)[key]
                else:
                    target = getattr(rb, {"obs": "observations", "next_obs": "next_observations"}.get(k, k))
                target[:n] = arrays[f"buffer/{k}"]
            rb.pos, rb.full = int(b["pos"]), bool(b["full"])
        set_rng_state(state["rng"], arrays)
    except (KeyError, TypeError, ValueError, RuntimeError, IndexError) as err:
        raise ValueError(
            f"the checkpoint does not fit this run ({type(err).__name__}: "
            f"{str(err).splitlines()[0][:160]}); delete checkpoint.npz to train this run again"
        ) from None


def finished_meta(out: Path, algo: str, settings: dict[str, Any]) -> dict[str, Any] | None:
    """The JSON of a finished run with ``settings`` in ``out``, or None when it has not finished."""
    if not (out / f"{algo}.json").exists():
        return None
    _, meta = read_agent_meta(out)
    if meta.get("settings") != json.loads(json.dumps(settings)):
        raise ValueError(f"{out / (algo + '.json')} describes another run than {SETTINGS}; use another --out")
    if not (out / f"{algo}.npz").is_file() or meta.get("weights_sha256") != file_sha256(out / f"{algo}.npz"):
        raise ValueError(f"{out / (algo + '.npz')} is missing or not the file {algo}.json describes; use another --out")
    return meta


def train_sb3(
    out: str | Path,
    algo: str,
    task: str,
    hyperparams: dict[str, Any],
    seed: int = 0,
    timesteps: int | None = None,
    log=print,
) -> dict[str, Any]:
    """Train ``algo`` ("ppo" or "sac") on ``task`` with ``hyperparams`` (one entry of a file in
    ``experiments/hyperparams/``, see :func:`experiments.agents.hyperparams.load_hyperparams`), or
    resume the run in ``out``. Writes ``train.json`` (the settings), ``training_log.csv`` (a row per
    evaluation), ``checkpoint.npz`` after every evaluation (:mod:`experiments.agents.runfolder`),
    ``learning_curve.png`` and, last, ``<algo>.npz`` + ``<algo>.json`` (:func:`save_agent`).

    Training runs in chunks of ``eval_freq`` env steps (whole PPO rollouts, whole SAC train-frequency
    blocks); each chunk starts from an env reset with seeds derived from ``seed`` and the chunk's
    index, so a run resumed from a checkpoint is the same computation as one never stopped and ends
    with the same weights. Deterministic under ``seed`` (one torch thread). Returns the metadata."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    from .curve import plot_training_log

    plan = plan_run(algo, task, hyperparams, seed, timesteps)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    check_settings(out, plan)
    done = finished_meta(out, algo, plan)
    if done is not None:
        log(f"{algo} {task}: {out} holds this run, finished; nothing to train")
        return done
    _one_torch_thread()
    torch.manual_seed(seed)
    env_kwargs, shaping, total, eval_freq = (
        plan["env_kwargs"],
        plan["shaping"],
        plan["total_timesteps"],
        plan["eval_freq"],
    )
    gamma = float(plan["algo_kwargs"].get("gamma", 0.99))

    def factory(rank: int):
        def _make():
            return make_rl_env(
                task,
                gamma=gamma,
                shaping=bool(shaping.get("enabled", False)),
                shaping_scale_deg=float(shaping.get("scale_deg", 10.0)),
                **env_kwargs,
            )

        return _make

    venv = DummyVecEnv([factory(i) for i in range(plan["n_envs"])])
    venv.seed(seed)
    eval_env = make_env(task, **env_kwargs)
    try:
        model = _make_model(plan, venv)
        meta = {
            "algo": algo,
            "task": task,
            "policy": plan["policy"],
            "env_kwargs": {**env_kwargs, "cortex": "eyes"},
            "shaping": shaping,
            "seed": seed,
            "n_envs": plan["n_envs"],
            "total_timesteps": total,
            "hyperparams": plan["hyperparams"],
            "settings": json.loads(json.dumps(plan)),
        }
        eval_seeds = episode_seeds(seed, plan["eval_episodes"], VALIDATION_STREAM)
        cb = _callback()
        log_path, ck = out / "training_log.csv", out / CHECKPOINT
        rows: list[dict] = []
        chunk, before_s, eval_s = 0, 0.0, 0.0
        t0 = time.perf_counter()

        def evaluation() -> None:
            nonlocal eval_s
            t = time.perf_counter()
            ev = evaluate(eval_env, SB3Agent(model, meta, out), eval_seeds, rng_seed=seed)
            eval_s += time.perf_counter() - t
            k = len(cb.train) if hasattr(cb, "train") else 0
            tr = cb.train if k else []
            row = {
                "env_steps": int(model.num_timesteps),
                "elapsed_s": round(before_s + time.perf_counter() - t0, 2),
                "success_rate": ev.success_rate,
                "mean_return": round(ev.mean_reward, 5),
                "mean_saccades": ev.mean_saccades,
                "train_episodes": k,
                "train_success_rate": round(sum(s for _, s in tr) / k, 4) if k else "",
                "train_return": round(sum(r for r, _ in tr) / k, 5) if k else "",
            }
            cb.train = []
            rows.append(row)
            append_csv_row(log_path, CURVE_COLUMNS, row)
            log(
                f"{algo} {task}: {row['env_steps']}/{total} steps, {row['elapsed_s']:.0f} s: validation success "
                f"{ev.success_rate:.2f}, return {ev.mean_reward:+.3f}; training episodes {k}"
            )

        if ck.exists():
            arrays, state = read_unit(ck, hint=f"delete {ck.name} to train this run again")
            if state.get("settings") != meta["settings"]:
                raise ValueError(f"{ck} belongs to another run than {SETTINGS}; delete it to train this run again")
            _restore(model, arrays, state)
            rows, chunk = list(state["log"]), int(state["chunk"])
            before_s, eval_s = float(state["elapsed_s"]), float(state["eval_s"])
            write_csv(log_path, list(CURVE_COLUMNS), rows)
            log(f"{algo} {task}: resuming {out} at {model.num_timesteps} env steps")
        else:
            log_path.unlink(missing_ok=True)
            evaluation()
        while model.num_timesteps < total:
            venv.seed(int(np.random.SeedSequence([seed, 3, chunk]).generate_state(1)[0] & 0x7FFFFFFF))
            model._last_obs = None  # learn() resets the env (with the seeds above) at the chunk's start
            model.learn(
                total_timesteps=min(eval_freq, total - model.num_timesteps),
                callback=cb,
                reset_num_timesteps=False,
                progress_bar=False,
            )
            chunk += 1
            evaluation()
            arrays, state = _capture(model)
            write_unit(
                ck,
                arrays,
                {
                    **state,
                    "settings": meta["settings"],
                    "log": rows,
                    "chunk": chunk,
                    "elapsed_s": before_s + time.perf_counter() - t0,
                    "eval_s": eval_s,
                },
            )
        wall = before_s + time.perf_counter() - t0
        meta.update(
            wall_s=round(wall, 1),
            eval_s=round(eval_s, 1),
            train_steps_per_s=round(model.num_timesteps / max(1e-9, wall - eval_s), 1),
            env_steps=int(model.num_timesteps),
            final=rows[-1],
        )
        plot_training_log(
            log_path, out / "learning_curve.png", title=f"{task}: {algo.upper()} ({plan['policy']}), seed {seed}"
        )
        meta = save_agent(out, model, algo, meta)
        ck.unlink(missing_ok=True)
        return meta
    finally:
        venv.close()
        eval_env.close()
