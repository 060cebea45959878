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
    ap.add_argument("--repeats", type=int, default=3, help="alternating timed runs; the best is kept (default 3)")
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
        best_env, best_bare = np.inf, np.inf
        for _ in range(args.repeats):
            env.reset(seed=0)
            best_env = min(best_env, env_loop(env, actions))
            head.reset(seed=0)
            best_bare = min(best_bare, bare_loop(head, actions, env.fixation_ms))
        env.close()
        rows.append((label, best_env / len(actions), best_bare / len(actions)))
    print(f"image {args.image_size}x{args.image_size} per eye, {args.steps} steps, best of {args.repeats}; "
          "1 step = saccade (~9 deg) + 250 ms fixation + render both eyes")
    print(f"{'configuration':42s} {'env ms':>8s} {'bare ms':>8s} {'env steps/s':>12s} {'overhead':>9s}")
    for label, t_env, t_bare in rows:
        print(f"{label:42s} {t_env * 1e3:8.2f} {t_bare * 1e3:8.2f} {1 / t_env:12.0f} {t_env / t_bare - 1:8.0%}")
    t_env, t_bare = rows[0][1], rows[0][2]
    print(f"target: >= 100 env steps/s (default config): {1 / t_env:.0f} -> {'met' if 1 / t_env >= 100 else 'not met'}")
    print(f"target: pipeline adds <= 15% over bare MuJoCo (default config): {t_env / t_bare - 1:.0%} -> "
          f"{'met' if t_env / t_bare - 1 <= 0.15 else 'not met'}")


if __name__ == "__main__":
    main()
