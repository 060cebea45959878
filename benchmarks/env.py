"""Env steps per second: beside a bare MuJoCo loop, and with two envs sharing the machine.

One env step = plan a saccade, run it and a 250 ms fixation (physics), render both eyes, and
(env only) sample both retinas, take the DPFTs, predict the post-saccadic retina with the
remapping models and score the step. The bare loop does the same saccades and renders with
``models.Head`` directly.

1. Solo: env and bare loop in this process, alternately, on the same action sequence.
2. Contention: the default env in one spawned process alone, then in two spawned processes at
   once (on a 2-core machine: one per core, each competing with the other for memory bandwidth
   and for any extra threads either starts). Each process's steps/s over its solo steps/s is the
   share of its speed it keeps. Run as the env runs (BLAS limited to one thread around its per-step
   product, ``conformal.blas_threads``; numba's parallel loops of the saccade model on one thread per
   64 saccades, ``models.limit_plan_threads``: one thread for one head); with ``--lifted``, then with
   each limit lifted in turn, as before it. The load average is printed: other jobs on the machine
   lower the ratios.

    python benchmarks/env.py [--steps 200] [--image-size 128] [--repeats 5] [--skip-contention] [--lifted]
"""

from __future__ import annotations

import argparse
import contextlib
import multiprocessing as mp
import os
import time
from typing import Any

import numpy as np

import envs
import models

SACCADE = np.array([[0.3, 0.1], [-0.3, -0.1]], np.float32)  # ~9 deg right/left: the eyes stay in range


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


def solo(args, actions) -> list[tuple[str, np.ndarray, np.ndarray]]:
    configs: list[tuple[str, dict[str, Any]]] = [
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
    return rows


#: the contention runs: (label, limit lifted)
LIMITS = (("as the env runs (both limits)", None), ("numba unlimited", "numba"), ("BLAS unlimited", "blas"))


def _worker(image_size: int, steps: int, repeats: int, lifted: str | None, barrier, results) -> None:
    """A spawned process: the default env, timed ``repeats`` times over ``steps`` steps, started
    together with the other workers at each barrier; ``lifted``: the thread limit taken off."""
    if lifted == "blas":  # the env as it was before the limit: BLAS on as many threads as it likes
        import conformal.remap_plan

        conformal.remap_plan.blas_threads = lambda n=1: contextlib.nullcontext()
    elif lifted == "numba":  # numba's default: every parallel loop on one thread per core
        models.limit_plan_threads(False)
    env = envs.BinocularSaccadeEnv(image_size=image_size)
    actions = np.tile(SACCADE, (steps // 2, 1))
    env.reset(seed=0)
    env_loop(env, actions[:20])
    best = np.inf
    for _ in range(repeats):
        env.reset(seed=0)
        barrier.wait()
        best = min(best, env_loop(env, actions) / len(actions))
    env.close()
    results.put(1.0 / best)


def contention(args, n_procs: int, lifted: str | None) -> list[float]:
    """Best steps/s of each of ``n_procs`` env processes running at once."""
    ctx = mp.get_context("spawn")
    barrier, results = ctx.Barrier(n_procs), ctx.Queue()
    procs = [
        ctx.Process(target=_worker, args=(args.image_size, args.steps, args.repeats, lifted, barrier, results))
        for _ in range(n_procs)
    ]
    for p in procs:
        p.start()
    out = [results.get(timeout=600) for _ in procs]
    for p in procs:
        p.join()
    return sorted(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=200, help="steps per timed run (default 200)")
    ap.add_argument("--image-size", type=int, default=128, help="pixels per side of each eye (default 128)")
    ap.add_argument("--repeats", type=int, default=5, help="timed runs, alternating env and bare loop (default 5)")
    ap.add_argument("--skip-contention", action="store_true", help="only the solo comparison with the bare loop")
    ap.add_argument(
        "--lifted",
        action="store_true",
        help="contention also with each thread limit lifted in turn (numba, then BLAS), as before the limits",
    )
    args = ap.parse_args()
    for name in ("steps", "image_size", "repeats"):
        if getattr(args, name) < (2 if name == "steps" else 1):
            ap.error(f"--{name.replace('_', '-')} must be a positive integer (steps >= 2)")
    actions = np.tile(SACCADE, (args.steps // 2, 1))

    rows = solo(args, actions)
    print(
        f"image {args.image_size}x{args.image_size} per eye, {len(actions)} steps, {args.repeats} alternating runs; "
        "1 step = saccade (~9 deg) + 250 ms fixation + render both eyes"
    )
    print(f"{'configuration':42s} {'env ms':>7s} {'bare ms':>8s} {'steps/s':>8s} {'env/bare':>9s} {'run to run':>11s}")
    for label, t_env, t_bare in rows:
        ratios = t_env / t_bare
        print(
            f"{label:42s} {t_env.min() * 1e3:7.2f} {t_bare.min() * 1e3:8.2f} {1 / t_env.min():8.0f} "
            f"{t_env.min() / t_bare.min():8.2f}x {ratios.min():5.2f}-{ratios.max():.2f}x"
        )
    print(
        "env ms, bare ms, steps/s and env/bare from the best run of each; run to run: each run's env time over "
        "the bare run beside it"
    )
    t_env, t_bare = rows[0][1].min(), rows[0][2].min()
    ok_speed, ok_ratio = 1 / t_env >= 150, t_env / t_bare <= 1.3
    print(f"target: default config >= 150 steps/s: {1 / t_env:.0f} -> {'met' if ok_speed else 'not met'}")
    print(f"target: default config <= 1.3x the bare loop: {t_env / t_bare:.2f}x -> {'met' if ok_ratio else 'not met'}")
    if args.skip_contention:
        return

    print(
        f"\ncontention: the default env in spawned processes, best of {args.repeats} runs of {len(actions)} steps each; "
        f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} before"
    )
    print(f"{'threads':32s} {'1 process':>10s} {'2 at once (each)':>18s} {'kept (each)':>14s}")
    kept_limited = None
    for label, lifted in LIMITS if args.lifted else LIMITS[:1]:
        alone = contention(args, 1, lifted)[0]
        pair = contention(args, 2, lifted)
        kept = [p / alone for p in pair]
        if lifted is None:
            kept_limited = kept
        print(f"{label:32s} {alone:8.0f}/s {pair[0]:8.0f} {pair[1]:7.0f}/s {kept[0]:7.0%} {kept[1]:5.0%}")
    assert kept_limited is not None, "LIMITS has the row of the env as it runs (lifted None)"
    ok = min(kept_limited) >= 0.8
    print(
        f"target: each of two envs at once keeps >= 80% of its solo speed: {min(kept_limited):.0%} -> "
        f"{'met' if ok else 'not met'}"
    )


if __name__ == "__main__":
    main()
