"""PPO on the batched engine: ``python -m experiments train --algo ppo --engine batched --device cuda``.

The learner (Schulman, Wolski, Dhariwal, Radford & Klimov 2017, clipped surrogate; GAE, Schulman et
al. 2016) is written here in torch, on the env's device, rather than taken from skrl (the separate
recipe :mod:`experiments.skrl_recipe` is skrl's). The reasons: ``train``'s folder promises need a
resume that ends with the *same* weights, and skrl's trainer owns the loop (a timestep-indexed update
schedule, private rollout counters and tracking state, checkpoints through ``torch.save``'s pickle),
so an exact resume would lean on its internals; and skrl reports a truncated episode as a termination
(its wrapper cannot bootstrap from the last observation), where this loop adds gamma * V(s_T) of the
ended episode's last observation (``info["final_obs"]``), as Stable-Baselines3 does on the CPU engine.

- The env: ``envs.BatchedBinocularSaccade`` (``autoreset_mode="same_step"``, observations as torch
  tensors on the device) with the agents' env settings (:data:`~experiments.agents.rollout.DEFAULT_ENV_KWARGS`,
  cell actions).
- The policy: :class:`CellActorCritic`, the wrap-around cortical convolution whose cell-logit map is the
  categorical over the M x N cells; the value reads a second encoder's pooled features.
- Shaping: ``envs.BatchedPotentialShaping``, F = gamma * Phi(s') - Phi(s) with ``envs.PotentialShaping``'s potential
  Phi = -(mean gaze error to the target) / scale_deg and Phi = 0 after a termination (Ng, Harada & Russell
  1999). The logged returns and success rates are the task's, without it.
- Training runs in chunks of ``eval_every`` PPO updates. Each chunk starts from an env reset with world
  seeds derived from the run's seed and the chunk's index, and ends with a validation row and
  ``checkpoint.npz`` (weights, Adam's state, the sampling generator, the log); so a run killed at any
  moment and started again with the same command is the same computation and ends with the same
  weights (tested on Warp's CPU backend; on CUDA, cuDNN is put in its deterministic mode).
- The end: the held-out episodes of ``evaluate`` (:func:`~experiments.agents.rollout.episode_seeds`,
  :data:`~experiments.agents.rollout.EVAL_STREAM`, seed 0, 100 episodes) run on the batched env, then
  ``ppo.npz`` (weights, :func:`~experiments.agents.saved.write_unit`) and ``ppo.json`` (the architecture,
  format :data:`FORMAT`, the weights' SHA-256). ``evaluate --policy DIR`` rebuilds the network from the
  JSON (:func:`load_batched_agent`) and runs it on the single env's held-out episodes.
"""

from __future__ import annotations

import json
import math
import re
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from ..folders import append_csv_row, write_csv, write_json
from .batched_folder import FORMAT, is_batched_folder
from .extractors import CorticalEncoder
from .rollout import DEFAULT_ENV_KWARGS, EVAL_STREAM, OBS_KEYS, VALIDATION_STREAM, Evaluation, episode_seeds
from .runfolder import CHECKPOINT, SETTINGS, check_settings
from .saved import check_weights_sha256, file_sha256, pack, read_unit, unpack, write_unit

__all__ = [
    "CURVE_COLUMNS",
    "BatchedPPOAgent",
    "CellActorCritic",
    "PPOTrainer",
    "check_device",
    "deterministic_torch",
    "load_batched_agent",
    "make_batched_env",
    "plan_batched",
    "run_batched_episodes",
    "train_batched",
]

CHUNK_STREAM = 3  # the world seeds of each training chunk's env reset
HELDOUT_SEED, HELDOUT_EPISODES = 0, 100  # evaluate's defaults (--seed 0 --episodes 100); fewer only in tests
CURVE_COLUMNS = (
    "env_steps",
    "updates",
    "elapsed_s",
    "success_rate",
    "mean_return",
    "mean_saccades",
    "train_episodes",
    "train_success_rate",
    "train_return",
    "env_steps_per_s",
)
_ALGO_KEYS = (
    "n_steps",
    "n_epochs",
    "n_minibatches",
    "learning_rate",
    "gamma",
    "gae_lambda",
    "clip_range",
    "ent_coef",
    "vf_coef",
    "max_grad_norm",
)


# --------------------------------------------------------------------------------------------- network
class CellActorCritic(nn.Module):
    """Actor: a :class:`~experiments.agents.extractors.CorticalEncoder` whose per-cell logit map is the
    categorical over cells (its 1x1 logit layer started at 1 % and zero bias: a near-uniform first
    policy). Critic: a second encoder's global features (pooled map, fovea, eye-position signal) through
    a ``vf_hidden``-wide tanh MLP. ``forward(obs)`` -> (logits (B, M*N), value (B,))."""

    def __init__(
        self,
        cortical_shape: tuple[int, ...],
        fovea_shape: tuple[int, ...],
        eyes_dim: int,
        channels: tuple[int, ...] = (16, 16),
        logit_gain: float = 1.0,
        vf_hidden: int = 64,
    ) -> None:
        super().__init__()
        if int(vf_hidden) < 1:
            raise ValueError(f"vf_hidden must be >= 1; got {vf_hidden!r}")
        self.config = {
            "class": "CellActorCritic",
            "cortical_shape": [int(s) for s in cortical_shape],
            "fovea_shape": [int(s) for s in fovea_shape],
            "eyes_dim": int(eyes_dim),
            "channels": [int(c) for c in channels],
            "logit_gain": float(logit_gain),
            "vf_hidden": int(vf_hidden),
        }
        enc: dict[str, Any] = dict(
            fovea_shape=tuple(fovea_shape),
            eyes_dim=int(eyes_dim),
            channels=tuple(channels),
            logit_gain=float(logit_gain),
        )
        self.actor = CorticalEncoder(tuple(cortical_shape), **enc)
        self.critic = CorticalEncoder(tuple(cortical_shape), **enc)
        self.value = nn.Sequential(
            nn.Linear(self.critic.global_dim, vf_hidden),
            nn.Tanh(),
            nn.Linear(vf_hidden, vf_hidden),
            nn.Tanh(),
            nn.Linear(vf_hidden, 1),
        )
        with torch.no_grad():
            self.actor.logit.weight.mul_(0.01)
            self.actor.logit.bias.zero_()  # type: ignore[union-attr]  # the logit layer has a bias

    @classmethod
    def from_config(cls, config: dict[str, Any]) -> CellActorCritic:
        """The network :attr:`config` describes (``ValueError`` for anything else)."""
        if not isinstance(config, dict) or config.get("class") != "CellActorCritic":
            raise ValueError(f"not a CellActorCritic architecture: {str(config)[:120]}")
        kw = {k: v for k, v in config.items() if k != "class"}
        return cls(**kw)

    def logits(self, obs: dict[str, torch.Tensor]) -> torch.Tensor:
        return self.actor(obs)[0]

    def forward(self, obs: dict[str, torch.Tensor]) -> tuple[torch.Tensor, torch.Tensor]:
        return self.actor(obs)[0], self.value(self.critic(obs)[1]).squeeze(-1)


def _obs(obs: dict) -> dict[str, torch.Tensor]:
    return {k: obs[k] for k in OBS_KEYS}


# --------------------------------------------------------------------------------------------- settings
def check_device(device: str | None) -> str | None:
    """``device`` if it is usable here: "cpu", "cuda" or "cuda:<i>" (None: CUDA when available);
    ``ValueError`` with one line saying why not."""
    if device is None or device == "cpu":
        return device
    if not re.fullmatch(r"cuda(:\d+)?", device):
        raise ValueError(f"--device must be cpu, cuda or cuda:<index>; got {device!r}")
    if not torch.cuda.is_available():
        raise ValueError(
            f"--device {device}: torch {torch.__version__} finds no CUDA device here; use --device cpu "
            "(Warp's CPU backend: slow, for small runs) or run on a machine with an NVIDIA GPU"
        )
    return device


def plan_batched(
    task: str,
    hyperparams: dict[str, Any],
    *,
    seed: int = 0,
    num_envs: int | None = None,
    device: str = "cpu",
    timesteps: int | None = None,
) -> dict[str, Any]:
    """The settings of one run (``train.json``) from one entry of ``ppo_batched.yml``; ``ValueError``
    for a bad or unknown key."""
    hp = json.loads(json.dumps(hyperparams))
    known = {
        "n_timesteps",
        "num_envs",
        "policy_kwargs",
        "env_kwargs",
        "shaping",
        "eval_every",
        "eval_episodes",
        "heldout_episodes",
        *_ALGO_KEYS,
    }
    unknown = sorted(set(hp) - known)
    if unknown:
        raise ValueError(
            f"unknown batched-PPO hyper-parameters: {', '.join(unknown)} (known: {', '.join(sorted(known))})"
        )
    n = int(num_envs if num_envs is not None else hp.get("num_envs", 64))
    if not 1 <= n <= 65536:
        raise ValueError(f"num_envs must be in [1, 65536]; got {n}")
    algo = {
        "n_steps": 16,
        "n_epochs": 4,
        "n_minibatches": 4,
        "learning_rate": 1e-3,
        "gamma": 0.9,
        "gae_lambda": 0.95,
        "clip_range": 0.2,
        "ent_coef": 0.01,
        "vf_coef": 0.5,
        "max_grad_norm": 0.5,
    }
    algo.update({k: hp[k] for k in _ALGO_KEYS if k in hp})
    for k in ("n_steps", "n_epochs", "n_minibatches"):
        if not (isinstance(algo[k], int) and algo[k] >= 1):
            raise ValueError(f"{k} must be an integer >= 1; got {algo[k]!r}")
    for k in ("learning_rate", "gamma", "gae_lambda", "clip_range", "ent_coef", "vf_coef", "max_grad_norm"):
        v = algo[k]
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
            raise ValueError(f"{k} must be a finite number >= 0; got {v!r}")
    if not 0 < algo["gamma"] <= 1 or algo["gae_lambda"] > 1:
        raise ValueError(f"gamma must be in (0, 1] and gae_lambda in [0, 1]; got {algo['gamma']}, {algo['gae_lambda']}")
    per_update = n * algo["n_steps"]
    if algo["n_minibatches"] > per_update:
        raise ValueError(f"n_minibatches ({algo['n_minibatches']}) exceeds a rollout's {per_update} samples")
    total = int(timesteps if timesteps is not None else hp.get("n_timesteps", per_update))
    if total < 1:
        raise ValueError(f"timesteps must be >= 1; got {total}")
    given = dict(hp.get("env_kwargs") or {})
    env_kwargs: dict[str, Any] = {"image_size": int(given.get("image_size", 96))}
    extra = sorted(set(given) - {"image_size", "task_kwargs"})
    if extra:
        raise ValueError(
            f"batched-PPO env_kwargs take image_size and task_kwargs only (the action is the cell); got {', '.join(extra)}"
        )
    if given.get("task_kwargs"):  # the task's own settings (e.g. max_saccades), checked here by the task
        if not isinstance(given["task_kwargs"], dict):
            raise ValueError(f"env_kwargs' task_kwargs must be a mapping; got {given['task_kwargs']!r:.60}")
        from envs.tasks import make_task

        try:
            make_task(task, **given["task_kwargs"])
        except (TypeError, ValueError) as err:
            raise ValueError(f"env_kwargs' task_kwargs: {str(err).splitlines()[0]}") from None
        env_kwargs["task_kwargs"] = dict(given["task_kwargs"])
    shaping = {"enabled": False, "scale_deg": 10.0, **dict(hp.get("shaping") or {})}
    pk = {"channels": [16, 16], "logit_gain": 1.0, "vf_hidden": 64, **dict(hp.get("policy_kwargs") or {})}
    eval_every, eval_episodes = int(hp.get("eval_every", 8)), int(hp.get("eval_episodes", 100))
    heldout = int(hp.get("heldout_episodes", HELDOUT_EPISODES))
    if eval_every < 1 or eval_episodes < 1 or heldout < 1:
        raise ValueError("eval_every, eval_episodes and heldout_episodes must be >= 1")
    return {
        "format": FORMAT,
        "algo": "ppo",
        "engine": "batched",
        "task": task,
        "seed": int(seed),
        "device": device,
        "num_envs": n,
        "updates": -(-total // per_update),
        "env_steps": -(-total // per_update) * per_update,
        "algo_kwargs": algo,
        "policy_kwargs": pk,
        "env_kwargs": env_kwargs,
        "shaping": shaping,
        "eval_every": eval_every,
        "eval_episodes": eval_episodes,
        "heldout": {"seed": HELDOUT_SEED, "episodes": heldout, "stream": EVAL_STREAM},
    }


def make_batched_env(task: str, num_envs: int, device: str | None, image_size: int, task_kwargs: dict | None = None):
    """The training env: ``envs.BatchedBinocularSaccade`` with the agents' env settings, cell actions,
    same-step autoreset and torch observations (``task_kwargs``: the task's own settings, as the single
    env takes them); a device Warp cannot use is a ``ValueError``."""
    import envs

    kwargs = {**DEFAULT_ENV_KWARGS, "image_size": int(image_size), "action_mode": "cell"}
    if task_kwargs:
        kwargs["task_kwargs"] = dict(task_kwargs)
    kwargs["remap_models"] = tuple(kwargs["remap_models"])
    try:
        return envs.BatchedBinocularSaccade(
            num_envs, device=device, task=task, autoreset_mode="same_step", output="torch", **kwargs
        )
    except RuntimeError as err:  # the env's device check (Warp's CUDA, a CPU-only torch): one line
        raise ValueError(str(err).splitlines()[0]) from None


def _world_seeds(seed: int, stream: int, index: int, n: int) -> list[int]:
    return [int(s) & 0x7FFFFFFF for s in np.random.SeedSequence([int(seed), stream, int(index)]).generate_state(n)]


# --------------------------------------------------------------------------------------------- episodes
def run_batched_episodes(
    env,
    model: CellActorCritic,
    seeds: np.ndarray,
    *,
    deterministic: bool = True,
    generator: torch.Generator | None = None,
) -> Evaluation:
    """One episode per reset seed on the batched env (``num_envs`` at a time; world i of a round starts
    from ``seeds[i]`` as ``BinocularSaccadeEnv.reset(seed=seeds[i])`` does): the task's return (no
    shaping), saccades and success, as :func:`~experiments.agents.rollout.evaluate` reports them."""
    seed_list = [int(s) for s in np.asarray(seeds).ravel()]
    if not seed_list:
        raise ValueError("need at least one episode")
    n = env.num_envs
    rows: list[tuple[float, int, bool]] = []
    for start in range(0, len(seed_list), n):
        batch = seed_list[start : start + n]
        k = len(batch)
        obs, _ = env.reset(seed=[batch[i % k] for i in range(n)])  # the spare worlds repeat seeds; not counted
        ret, sacc, success = np.zeros(n), np.zeros(n, np.int64), np.zeros(n, bool)
        running = np.zeros(n, bool)
        running[:k] = True
        while running.any():
            with torch.no_grad():
                a = _act(model.logits(_obs(obs)), deterministic, generator)
            obs, r, te, tr, info = env.step(a)
            ret[running] += r[running]
            sacc[running] += 1
            done = (te | tr) & running
            if done.any():
                success[done] = np.asarray(info["final_info"]["success"])[done]
            running &= ~done
        rows += [(float(ret[i]), int(sacc[i]), bool(success[i])) for i in range(k)]
    res = np.array(rows, np.float64)
    return Evaluation(
        success_rate=float(res[:, 2].mean()),
        mean_reward=float(res[:, 0].mean()),
        mean_saccades=float(res[:, 1].mean()),
        episodes=len(rows),
    )


def _act(logits: torch.Tensor, deterministic: bool, generator: torch.Generator | None) -> torch.Tensor:
    if deterministic:
        return logits.argmax(dim=-1)
    return torch.multinomial(torch.softmax(logits, dim=-1), 1, generator=generator).squeeze(-1)


# --------------------------------------------------------------------------------------------- PPO
class _Rollout:
    """One rollout of ``n_steps`` batched steps on the device: observations, actions, log-probabilities,
    values, rewards (task + shaping + gamma * V(s_T) on truncation) and episode ends."""

    def __init__(self, obs: dict[str, torch.Tensor], steps: int) -> None:
        t = steps
        self.obs = {k: torch.empty((t,) + tuple(v.shape), dtype=v.dtype, device=v.device) for k, v in obs.items()}
        n, dev = next(iter(obs.values())).shape[0], next(iter(obs.values())).device
        self.actions = torch.empty((t, n), dtype=torch.long, device=dev)
        self.logp, self.values, self.rewards, self.dones = (torch.empty((t, n), device=dev) for _ in range(4))


class PPOTrainer:
    """The PPO loop of :func:`train_batched` (state: model, Adam, the sampling generator, counters):
    :meth:`chunk_of` runs one chunk of updates from a seeded env reset; :meth:`capture` / :meth:`restore`
    its state as arrays and JSON."""

    def __init__(self, plan: dict[str, Any], env, model: CellActorCritic, log) -> None:
        from envs import BatchedPotentialShaping

        self.plan, self.env, self.model, self.log = plan, env, model, log
        a = plan["algo_kwargs"]
        self.a = a
        self.dev = env.device
        self.opt = torch.optim.Adam(model.parameters(), lr=a["learning_rate"], eps=1e-5)
        self.gen = torch.Generator(device=self.dev)
        self.gen.manual_seed(int(np.random.SeedSequence([plan["seed"], 4]).generate_state(1)[0]))
        sh = plan["shaping"]
        self.shaping = BatchedPotentialShaping(env, a["gamma"], sh["scale_deg"]) if sh.get("enabled") else None
        self.updates, self.env_steps, self.chunk = 0, 0, 0
        self.train_eps: list[tuple[float, bool]] = []

    # -- state
    def capture(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        arrays: dict[str, np.ndarray] = {}
        state = {
            "model": pack(self.model.state_dict(), "model", arrays),
            "optimizer": pack(self.opt.state_dict(), "optimizer", arrays),
            "updates": self.updates,
            "env_steps": self.env_steps,
            "chunk": self.chunk,
        }
        arrays["generator"] = self.gen.get_state().numpy().copy()
        return arrays, state

    def restore(self, arrays: dict[str, np.ndarray], state: dict[str, Any]) -> None:
        try:
            self.model.load_state_dict(unpack(state["model"], arrays, tensors=True), strict=True)
            self.opt.load_state_dict(unpack(state["optimizer"], arrays, tensors=True))
            self.gen.set_state(torch.from_numpy(arrays["generator"].astype(np.uint8)))
            self.updates, self.env_steps, self.chunk = (
                int(state["updates"]),
                int(state["env_steps"]),
                int(state["chunk"]),
            )
        except (KeyError, TypeError, ValueError, RuntimeError) as err:
            raise ValueError(
                f"the checkpoint does not fit this run ({type(err).__name__}: "
                f"{str(err).splitlines()[0][:160]}); delete checkpoint.npz to train this run again"
            ) from None

    # -- one chunk: reset, rollouts and updates
    def chunk_of(self, n_updates: int) -> None:
        env, a, n = self.env, self.a, self.env.num_envs
        obs, _ = env.reset(seed=_world_seeds(self.plan["seed"], CHUNK_STREAM, self.chunk, n))
        obs = _obs(obs)
        if self.shaping is not None:
            self.shaping.start()
        ret = np.zeros(n)
        for _ in range(n_updates):
            buf = _Rollout(obs, a["n_steps"])
            for t in range(a["n_steps"]):
                with torch.no_grad():
                    logits, v = self.model(obs)
                    act = _act(logits, False, self.gen)
                    logp = torch.log_softmax(logits, dim=-1).gather(1, act[:, None]).squeeze(1)
                for k in OBS_KEYS:
                    buf.obs[k][t] = obs[k]
                buf.actions[t], buf.logp[t], buf.values[t] = act, logp, v
                nxt, r, te, tr, info = env.step(act)
                done = te | tr
                reward = np.asarray(r, np.float64).copy()
                ret += reward
                if done.any():
                    fin = info["final_info"]["success"]
                    for i in np.flatnonzero(done):
                        self.train_eps.append((float(ret[i]), bool(fin[i])))
                    ret[done] = 0.0
                if self.shaping is not None:
                    reward += self.shaping.step(info, te, done)
                rew = torch.as_tensor(reward, dtype=torch.float32, device=self.dev)
                if tr.any():  # bootstrap a truncated episode from its last observation's value
                    idx = torch.as_tensor(np.flatnonzero(tr), device=self.dev)
                    final = {k: info["final_obs"][k][idx] for k in OBS_KEYS}
                    with torch.no_grad():
                        rew[idx] += a["gamma"] * self.model(final)[1]
                buf.rewards[t] = rew
                buf.dones[t] = torch.as_tensor(done, dtype=torch.float32, device=self.dev)
                obs = _obs(nxt)
                self.env_steps += n
            with torch.no_grad():
                last = self.model(obs)[1]
            self._update(buf, last)
            self.updates += 1
        self.chunk += 1

    def _update(self, buf: _Rollout, last_value: torch.Tensor) -> None:
        a = self.a
        T = buf.rewards.shape[0]
        adv = torch.zeros_like(buf.rewards)
        gae = torch.zeros_like(last_value)
        for t in reversed(range(T)):  # GAE (Schulman et al. 2016), cut at every episode end
            nxt = last_value if t == T - 1 else buf.values[t + 1]
            live = 1.0 - buf.dones[t]
            delta = buf.rewards[t] + a["gamma"] * nxt * live - buf.values[t]
            gae = delta + a["gamma"] * a["gae_lambda"] * live * gae
            adv[t] = gae
        returns = adv + buf.values
        flat = {k: v.reshape((-1,) + tuple(v.shape[2:])) for k, v in buf.obs.items()}
        act, logp0, adv, returns = (x.reshape(-1) for x in (buf.actions, buf.logp, adv, returns))
        size = act.shape[0]
        mb = -(-size // a["n_minibatches"])
        for _ in range(a["n_epochs"]):
            perm = torch.randperm(size, generator=self.gen, device=self.dev)
            for s in range(0, size, mb):
                i = perm[s : s + mb]
                logits, v = self.model({k: x[i] for k, x in flat.items()})
                logp_all = torch.log_softmax(logits, dim=-1)
                logp = logp_all.gather(1, act[i][:, None]).squeeze(1)
                entropy = -(logp_all.exp() * logp_all).sum(dim=-1).mean()
                A = adv[i]
                if A.numel() > 1:
                    A = (A - A.mean()) / (A.std() + 1e-8)
                ratio = torch.exp(logp - logp0[i])
                policy_loss = -torch.min(ratio * A, ratio.clamp(1 - a["clip_range"], 1 + a["clip_range"]) * A).mean()
                value_loss = ((returns[i] - v) ** 2).mean()
                loss = policy_loss + a["vf_coef"] * value_loss - a["ent_coef"] * entropy
                self.opt.zero_grad(set_to_none=True)
                loss.backward()
                nn.utils.clip_grad_norm_(self.model.parameters(), a["max_grad_norm"])
                self.opt.step()


def deterministic_torch(device: str) -> None:
    """The same computation on every run: one torch thread on the CPU (numba's threading layer, the
    env's, started first: its start resets OpenMP's thread count; see ``experiments.agents.sb3``), cuDNN's
    deterministic algorithms on CUDA."""
    if device == "cpu":
        import numba

        numba.get_num_threads()
        torch.set_num_threads(1)
    else:
        torch.backends.cudnn.deterministic = True
        torch.backends.cudnn.benchmark = False


# --------------------------------------------------------------------------------------------- saving
def _save(out: Path, model: CellActorCritic, meta: dict[str, Any]) -> dict[str, Any]:
    """``ppo.npz`` (the weights, with the metadata inside) then ``ppo.json`` (metadata, architecture,
    the weights' SHA-256), each atomically."""
    arrays: dict[str, np.ndarray] = {}
    skeleton = pack({k: v.cpu() for k, v in model.state_dict().items()}, "policy", arrays)
    meta = {
        **meta,
        "format": FORMAT,
        "algo": "ppo",
        "architecture": model.config,
        "versions": {"torch": torch.__version__, "numpy": np.__version__},
    }
    write_unit(out / "ppo.npz", arrays, {**meta, "state_dict": skeleton})
    meta["weights_sha256"] = file_sha256(out / "ppo.npz")
    write_json(out / "ppo.json", meta)
    return meta


class BatchedPPOAgent:
    """A batched-trained :class:`CellActorCritic` as a policy of the single env
    (:func:`~experiments.agents.rollout.evaluate`): the most likely cell (``deterministic``) or a
    sample (seeded through :meth:`seed`)."""

    def __init__(
        self, model: CellActorCritic, metadata: dict[str, Any], path: Path, deterministic: bool = True
    ) -> None:
        self.model, self.metadata, self.path = model.eval(), metadata, Path(path)
        self.deterministic = bool(deterministic)
        self.name = f"ppo-batched:{path}"
        self.generator = torch.Generator().manual_seed(0)

    def seed(self, seed: int) -> None:
        self.generator = torch.Generator().manual_seed(int(seed))

    def act(self, obs: dict, rng=None) -> int:
        t = {k: torch.as_tensor(np.asarray(obs[k], np.float32))[None] for k in OBS_KEYS}
        with torch.no_grad():
            return int(_act(self.model.logits(t), self.deterministic, self.generator)[0])


def load_batched_agent(directory: str | Path, deterministic: bool = True) -> BatchedPPOAgent:
    """The agent of a finished ``train --engine batched`` folder, rebuilt from ``ppo.json``'s
    architecture with the weights of ``ppo.npz`` (``allow_pickle=False``; SHA-256 checked); on the CPU."""
    d = Path(directory)
    jpath, wpath = d / "ppo.json", d / "ppo.npz"
    try:
        meta = json.loads(jpath.read_text(encoding="utf-8"))
        if not isinstance(meta, dict) or meta.get("format") != FORMAT:
            raise ValueError(f"format {meta.get('format') if isinstance(meta, dict) else None!r}")
        meta["task"], meta["env_kwargs"] = str(meta["task"]), dict(meta["env_kwargs"])
    except (OSError, UnicodeDecodeError, KeyError, TypeError, ValueError) as err:
        raise ValueError(
            f"{jpath} is not a batched-PPO metadata file ({type(err).__name__}: {str(err)[:80]}); retrain"
        ) from None
    if not wpath.is_file():
        raise FileNotFoundError(f"{d} is not a saved batched-PPO agent: missing ppo.npz")
    check_weights_sha256(wpath, meta.get("weights_sha256"), "ppo.json")
    arrays, inner = read_unit(wpath)
    try:
        model = CellActorCritic.from_config(meta["architecture"])
        model.load_state_dict(unpack(inner["state_dict"], arrays, tensors=True), strict=True)
    except (KeyError, TypeError, ValueError, RuntimeError) as err:
        raise ValueError(
            f"{wpath}: the saved network cannot be rebuilt ({type(err).__name__}: "
            f"{str(err).splitlines()[0][:160]}); retrain"
        ) from None
    return BatchedPPOAgent(model, meta, d, deterministic)


# --------------------------------------------------------------------------------------------- training
def train_batched(
    out: str | Path,
    task: str,
    hyperparams: dict[str, Any],
    *,
    seed: int = 0,
    num_envs: int | None = None,
    device: str | None = None,
    timesteps: int | None = None,
    log=print,
) -> dict[str, Any]:
    """Train (or resume, or report the finished run in) ``out``: see the module docstring. Writes
    ``train.json`` first, ``training_log.csv`` (a row per validation), ``checkpoint.npz`` after each,
    ``learning_curve.png``, and last ``ppo.npz`` + ``ppo.json``. Returns the metadata."""
    from .curve import plot_training_log

    check_device(device)
    if device is None:
        device = "cuda" if torch.cuda.is_available() else "cpu"
    plan = plan_batched(task, hyperparams, seed=seed, num_envs=num_envs, device=device, timesteps=timesteps)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    check_settings(out, plan)
    if (out / "ppo.json").exists():
        if not is_batched_folder(out):
            raise ValueError(f"{out / 'ppo.json'} is not a batched-PPO run's; use another --out")
        meta = json.loads((out / "ppo.json").read_text(encoding="utf-8"))
        if meta.get("settings") != plan or meta.get("weights_sha256") != file_sha256(out / "ppo.npz"):
            raise ValueError(
                f"{out / 'ppo.json'} describes another run than {SETTINGS}, or ppo.npz was altered; use another --out"
            )
        log(f"ppo {task}: {out} holds this run, finished; nothing to train")
        return meta
    deterministic_torch(device)
    env = make_batched_env(
        task, plan["num_envs"], device, plan["env_kwargs"]["image_size"], plan["env_kwargs"].get("task_kwargs")
    )
    try:
        sp = env.single_observation_space
        torch.manual_seed(seed)
        policy_kwargs: dict[str, Any] = {
            k: (tuple(v) if k == "channels" else v) for k, v in plan["policy_kwargs"].items()
        }
        model = CellActorCritic(
            sp["cortical"].shape, sp["fovea"].shape, int(np.prod(sp["eyes"].shape)), **policy_kwargs
        )
        model = model.to(env.device)
        trainer = PPOTrainer(plan, env, model, log)
        val_seeds = episode_seeds(seed, plan["eval_episodes"], VALIDATION_STREAM)
        log_path, ck = out / "training_log.csv", out / CHECKPOINT
        rows: list[dict] = []
        before_s, eval_s = 0.0, 0.0
        t0 = time.perf_counter()

        def validation() -> None:
            nonlocal eval_s
            t = time.perf_counter()
            ev = run_batched_episodes(env, model, val_seeds)
            eval_s += time.perf_counter() - t
            tr, k = trainer.train_eps, len(trainer.train_eps)
            wall = before_s + time.perf_counter() - t0
            row = {
                "env_steps": trainer.env_steps,
                "updates": trainer.updates,
                "elapsed_s": round(wall, 2),
                "success_rate": ev.success_rate,
                "mean_return": round(ev.mean_reward, 5),
                "mean_saccades": ev.mean_saccades,
                "train_episodes": k,
                "train_success_rate": round(sum(s for _, s in tr) / k, 4) if k else "",
                "train_return": round(sum(r for r, _ in tr) / k, 5) if k else "",
                "env_steps_per_s": round(trainer.env_steps / max(1e-9, wall - eval_s), 1),
            }
            trainer.train_eps = []
            rows.append(row)
            append_csv_row(log_path, CURVE_COLUMNS, row)
            log(
                f"ppo {task} (batched, {plan['num_envs']} worlds, {device}): {row['env_steps']}/{plan['env_steps']} "
                f"steps, {wall:.0f} s: validation success {ev.success_rate:.2f}, return {ev.mean_reward:+.3f}; "
                f"training episodes {k}, success {row['train_success_rate']}"
            )

        if ck.exists():
            arrays, state = read_unit(ck, hint=f"delete {ck.name} to train this run again")
            if state.get("settings") != plan:
                raise ValueError(f"{ck} belongs to another run than {SETTINGS}; delete it to train this run again")
            trainer.restore(arrays, state)
            rows = list(state["log"])
            before_s, eval_s = float(state["elapsed_s"]), float(state["eval_s"])
            write_csv(log_path, list(CURVE_COLUMNS), rows)
            log(f"ppo {task}: resuming {out} at {trainer.env_steps} env steps")
        else:
            log_path.unlink(missing_ok=True)
            validation()
        while trainer.updates < plan["updates"]:
            trainer.chunk_of(min(plan["eval_every"], plan["updates"] - trainer.updates))
            validation()
            arrays, state = trainer.capture()
            write_unit(
                ck,
                arrays,
                {
                    **state,
                    "settings": plan,
                    "log": rows,
                    "elapsed_s": before_s + time.perf_counter() - t0,
                    "eval_s": eval_s,
                },
            )
        h = plan["heldout"]
        t = time.perf_counter()
        held = run_batched_episodes(env, model, episode_seeds(h["seed"], h["episodes"], h["stream"]))
        eval_s += time.perf_counter() - t
        wall = before_s + time.perf_counter() - t0
        meta = {
            "algo": "ppo",
            "engine": "batched",
            "task": task,
            "seed": seed,
            "device": device,
            "device_name": torch.cuda.get_device_name(env.device) if env.device.type == "cuda" else "cpu",
            "num_envs": plan["num_envs"],
            "env_kwargs": {**plan["env_kwargs"], "action_mode": "cell"},
            "shaping": plan["shaping"],
            "settings": plan,
            "env_steps": trainer.env_steps,
            "wall_s": round(wall, 1),
            "eval_s": round(eval_s, 1),
            "train_steps_per_s": round(trainer.env_steps / max(1e-9, wall - eval_s), 1),
            "final": rows[-1],
            "heldout_batched": {**held.as_dict(), "seed": h["seed"], "deterministic": True},
        }
        plot_training_log(
            log_path,
            out / "learning_curve.png",
            title=f"{task}: PPO (batched, {plan['num_envs']} worlds, {device}), seed {seed}",
        )
        meta = _save(out, model.cpu(), meta)
        ck.unlink(missing_ok=True)
        return meta
    finally:
        env.close()
