"""Env steps per second beside a bare MuJoCo loop doing the same physics and renders.

One env step = plan a saccade, run it and a 250 ms fixation (physics), render both eyes, and
(env only) sample both retinas, take the DPFTs, predict the post-saccadic retina with the
remapping models and score the step. The bare loop does the same saccades and renders with
``models.Head`` directly. Both run in this process, alternately, on the same action sequence.

    python benchmarks/env.py [--steps 200] [--image-size 128]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import envs


def bare_loop(head, actions, fixation_ms: int) -> float:
    t0 = time.perf_counter()
    for a in actions:
        plan = head.plan_saccade(*(a * np.radians(30.0)))
        head.start_saccade(plan)
        head.step_ms(plan.end_ms - head.time_ms + fixation_ms)
        head.render()
    return time.perf_counter() - t0


def env_loop(env, actions) -> float:
    t0 = time.perf_counter()
    for a in actions:
        env.step(a)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=200, help="steps per timed run (default 200)")
    ap.add_argument("--image-size", type=int, default=128, help="pixels per side of each eye (default 128)")
    ap.add_argument("--repeats", type=int, default=5, help="alternating timed runs of env and bare loop (default 5)")
    args = ap.parse_args()
    # alternate right and left saccades of ~9 deg so the eyes stay in range
    actions = np.array([[0.3, 0.1], [-0.3, -0.1]] * (args.steps // 2), np.float32)
    configs = [
        ("env: all 3 remapping models (default)", {}),
        ("env: homography only", {"remap_models": ("homography",)}),
        ("env: homography only, grayscale", {"remap_models": ("homography",), "grayscale": True}),
    ]
    rows = []
    for label, kw in configs:
        env = envs.BinocularSaccadeEnv(image_size=args.image_size, **kw)
        env.reset(seed=0)
        head = env.head
        env_loop(env, actions[:20])  # warm-up: compiled kernels, caches
        t_env, t_bare = [], []
        for _ in range(args.repeats):  # alternate, so both see the same machine state
            env.reset(seed=0)
            t_env.append(env_loop(env, actions) / len(actions))
            head.reset(seed=0)
            t_bare.append(bare_loop(head, actions, env.fixation_ms) / len(actions))
        env.close()
        rows.append((label, np.array(t_env), np.array(t_bare)))
    print(f"image {args.image_size}x{args.image_size} per eye, {args.steps} steps, {args.repeats} alternating runs; "
          "1 step = saccade (~9 deg) + 250 ms fixation + render both eyes")
    print(f"{'configuration':42s} {'env ms':>7s} {'bare ms':>8s} {'steps/s':>8s} {'overhead':>9s} {'run to run':>11s}")
    for label, t_env, t_bare in rows:
        ratios = t_env / t_bare - 1
        print(f"{label:42s} {t_env.min() * 1e3:7.2f} {t_bare.min() * 1e3:8.2f} {1 / t_env.min():8.0f} "
              f"{t_env.min() / t_bare.min() - 1:9.0%} {ratios.min():5.0%}-{ratios.max():.0%}")
    print("env ms, bare ms, steps/s and overhead from the best run of each; run to run: each run's env time over "
          "the bare run beside it")
    t_env, t_bare = rows[0][1].min(), rows[0][2].min()
    print(f"target: >= 100 env steps/s (default config): {1 / t_env:.0f} -> {'met' if 1 / t_env >= 100 else 'not met'}")
    print(f"target: pipeline adds <= 15% over bare MuJoCo (default config): {t_env / t_bare - 1:.0%} -> "
          f"{'met' if t_env / t_bare - 1 <= 0.15 else 'not met'}")


if __name__ == "__main__":
    main()
