"""Env-steps/s of the batched PPO trainer (``train --algo ppo --engine batched``) beside the bare batched env.

For each number of worlds, in one process and on one env: the bare env stepped with uniformly random
cells (the baseline, timed before and after the trainer, averaged), and the trainer's chunks (policy forward, sampling, shaping, rollout storage and
the PPO updates: :class:`experiments.agents.batched_ppo.PPOTrainer`). The ratio trainer / env is the share
of the env's speed that training keeps.

    python benchmarks/batched_ppo.py --device cpu --num-envs 4 8 16 --steps 4
    python benchmarks/batched_ppo.py --device cuda --num-envs 1024 2048 4096 --steps 16 --image-size 96

Each configuration is warmed up (kernel compilation, one update) before it is timed.
"""

from __future__ import annotations

import argparse
import csv
import time

import numpy as np


def measure(task: str, n: int, device: str, image_size: int, steps: int, updates: int) -> dict:
    import torch

    from experiments.agents.batched_ppo import (
        CellActorCritic,
        PPOTrainer,
        deterministic_torch,
        make_batched_env,
        plan_batched,
    )
    from experiments.agents.hyperparams import load_hyperparams

    hp = load_hyperparams("ppo_batched", task)
    hp.update(n_steps=steps, env_kwargs={"image_size": image_size}, eval_every=updates)
    plan = plan_batched(task, hp, num_envs=n, device=device, timesteps=n * steps * updates)
    deterministic_torch(device)
    env = make_batched_env(task, n, device, image_size)
    try:
        sp = env.single_observation_space
        torch.manual_seed(0)
        model = CellActorCritic(
            sp["cortical"].shape,
            sp["fovea"].shape,
            int(np.prod(sp["eyes"].shape)),
            channels=tuple(plan["policy_kwargs"]["channels"]),
        ).to(env.device)
        trainer = PPOTrainer(plan, env, model, log=lambda m: None)
        sync = (lambda: torch.cuda.synchronize(env.device)) if env.device.type == "cuda" else (lambda: None)
        rng = np.random.default_rng(0)
        cells = env.single_action_space.n
        env.reset(seed=list(range(n)))
        env.step(rng.integers(cells, size=n))  # warm-up: kernels
        trainer.chunk_of(1)  # warm-up: the update's kernels
        sync()

        def bare_run() -> float:
            t = time.perf_counter()
            env.reset(seed=list(range(n)))
            for _ in range(steps * updates):
                env.step(rng.integers(cells, size=n))
            sync()
            return time.perf_counter() - t

        before = bare_run()
        t = time.perf_counter()
        trainer.chunk_of(updates)
        sync()
        train_s = time.perf_counter() - t
        after = bare_run()  # the baseline on both sides of the trainer: a shared machine's load drifts
        bare = n * steps * updates / ((before + after) / 2)
        train = n * steps * updates / train_s
    finally:
        env.close()
    return {
        "device": device,
        "num_envs": n,
        "image_size": image_size,
        "steps_per_update": steps,
        "updates": updates,
        "env_steps_per_s": round(bare, 2),
        "env_before_s": round(before, 2),
        "env_after_s": round(after, 2),
        "trainer_s": round(train_s, 2),
        "trainer_env_steps_per_s": round(train, 2),
        "ratio": round(train / bare, 3),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--task", default="search", choices=("fixate", "search"))
    ap.add_argument("--num-envs", type=int, nargs="+", default=[4, 8, 16])
    ap.add_argument("--steps", type=int, default=4, help="steps per world per PPO update")
    ap.add_argument("--updates", type=int, default=1, help="timed PPO updates")
    ap.add_argument("--image-size", type=int, default=32)
    ap.add_argument("--csv", help="write the rows to this CSV file")
    args = ap.parse_args(argv)
    rows = [measure(args.task, n, args.device, args.image_size, args.steps, args.updates) for n in args.num_envs]
    print(f"{args.device}, {args.image_size} px, {args.steps} steps per world x {args.updates} update(s)")
    print("| worlds | env alone (env-steps/s) | env before / after (s) | trainer (env-steps/s) | trainer / env |")
    print("|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['num_envs']} | {r['env_steps_per_s']:.1f} | {r['env_before_s']:.1f} / {r['env_after_s']:.1f} | "
            f"{r['trainer_env_steps_per_s']:.1f} | {r['ratio']:.2f} |"
        )
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
