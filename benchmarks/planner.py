"""The batched env's host side per world and step: ``models.planner`` beside the per-world objects.

Per env step the host of ``envs.BatchedBinocularSaccade`` resets the worlds whose episode ended
(scene layout and task, from each world's seed), plans every other world's saccade, writes the
command tables the device's servo follows, and advances the worlds' clocks and eye-position
signals. The baseline does the same with one ``models.Head`` and ``models.SaccadePlan`` per world
(``Head.reset`` + the task, ``models.plan_clipped``, ``SaccadePlan.angles`` for the table,
``SaccadePlan.eye_position_signal``), as the batched env did before the planner was vectorised. A
second table times the command tables and the eye-position signals by the general kernels and by the
fast ones (``models._plan_kernels.command_rows``, the signal's tabulated Gaussian CDF) in the same
process, and checks that every bit agrees. No GPU extra needed: this is numpy and numba on the host.

    python benchmarks/planner.py [--num-envs 64 1024 4096] [--steps 5] [--task search] [--resets 0.1]
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numba
import numpy as np

import models
from envs.tasks import TASKS
from models import BatchedPlanner, SettledReset, plan_clipped

FIXATION_MS = 250


def random_actions(rng: np.random.Generator, n: int) -> np.ndarray:
    return rng.uniform(-0.4, 0.4, (n, 2)) * np.radians(30.0)  # the env's default 30 deg action scale


def baseline(task, n: int, steps: int, resets: float) -> float:
    """Seconds per world and step with a Head and SaccadePlans per world."""
    heads = [models.Head(task.scene, 32, seed=i) for i in range(n)]
    rngs = [np.random.default_rng(i) for i in range(n)]
    rng = np.random.default_rng(0)
    for h, r in zip(heads, rngs):
        task.initialize_episode(h, r)
    for k in range(steps + 1):  # the first step builds the burst generator's table
        if k == 1:
            t0 = time.perf_counter()
        hv, done = random_actions(rng, n), rng.random(n) < resets
        for i, head in enumerate(heads):
            if done[i]:
                head.reset(seed=int(rngs[i].integers(2**31 - 1)))
                task.initialize_episode(head, rngs[i])
            plan, _ = plan_clipped(head, hv[i, 0], hv[i, 1], 1.0)
            span = plan.end_ms - plan.onset_ms
            plan.angles(plan.onset_ms + np.arange(span + 1.0))
            plan.eye_position_signal(float(plan.end_ms + FIXATION_MS))
            # (the head stays where it was: the next plan starts from the same fixation)
    return (time.perf_counter() - t0) / (n * steps)


def cpu_name() -> str:
    """The host's processor, as /proc/cpuinfo names it (or the platform's word for it)."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def batched(task, n: int, steps: int, resets: float, parts: dict | None = None) -> float:
    """Seconds per world and step with the vectorised planner (one scratch head); with ``parts``, each
    part's seconds per world and step added into it (resets, plan, commands, start)."""
    head = models.Head(task.scene, 32, seed=0)
    settled, planner = SettledReset(head), BatchedPlanner(head, n)
    rngs = [np.random.default_rng(i) for i in range(n)]
    rng = np.random.default_rng(0)

    def reset(idx):  # as the batched env resets: all at once (BatchedPlanner.take_settled)
        seeds = [int(rngs[i].integers(2**31 - 1)) for i in idx]
        planner.take_settled(idx, settled, seeds, [task.placements(rngs[i]) for i in idx])

    reset(range(n))
    worlds = np.arange(n)
    spent = dict.fromkeys(PARTS, 0.0)

    def timed(name, f, *a):
        t = time.perf_counter()
        out = f(*a)
        spent[name] += time.perf_counter() - t
        return out

    for k in range(steps + 1):  # the first step loads numba's compiled kernels
        if k == 1:
            t0 = time.perf_counter()
            spent = dict.fromkeys(PARTS, 0.0)
        hv, done = random_actions(rng, n), rng.random(n) < resets
        timed("resets", reset, np.flatnonzero(done))
        plans, _ = timed("plan", planner.plan, worlds, hv, np.ones(n))
        timed("commands", planner.commands, plans)
        timed("start", planner.start, worlds, plans, plans.end_ms - plans.onset_ms + FIXATION_MS)
        planner.eye_position_signal()
    if parts is not None:
        for name, v in spent.items():
            parts[name] = v / (n * steps)
    return (time.perf_counter() - t0) / (n * steps)


def paths(task, n: int, steps: int, repeats: int = 5) -> dict[str, tuple[float, float, bool]]:
    """The command tables and the eye-position signals of ``steps`` steps' plans by the general kernels (the
    tables as ``SaccadePlans.angles`` at an (n, T) array of times, the signal's Gaussian CDF computed at every
    knot: the code before ``command_rows`` and the CDF table) and by the fast ones, in this process: per
    part (seconds per world and call, general then fast, the median of ``repeats``, and whether every
    bit agrees)."""
    head = models.Head(task.scene, 32, seed=0)
    settled, planner = SettledReset(head), BatchedPlanner(head, n)
    planner.take_settled(
        np.arange(n), settled, list(range(n)), [task.placements(np.random.default_rng(i)) for i in range(n)]
    )
    rng = np.random.default_rng(0)
    spent: dict[str, list[float]] = {}
    same = {"tables": True, "signal": True}
    for _ in range(steps):
        plans, _ = planner.plan(np.arange(n), random_actions(rng, n), np.ones(n))
        advance = plans.end_ms - plans.onset_ms + FIXATION_MS
        for part, ok in models.time_kernel_paths(
            plans, (planner.time_ms + advance)[:, None].astype(float), spent, repeats
        ).items():
            same[part] &= ok
        planner.start(np.arange(n), plans, advance)
    med = {k: float(np.median(v)) / n for k, v in spent.items()}
    return {p: (med[f"{p}, general"], med[f"{p}, fast"], same[p]) for p in same}


#: the host's parts of a step: resets (layout, task, hand-over), plans (SaccadePlans: profiles, settle
#: times, rotations), command tables (the executed angles every ms), start (clocks, eye-position signals)
PARTS = ("resets", "plan", "commands", "start")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--num-envs", type=int, nargs="+", default=[64, 1024, 4096])
    ap.add_argument("--steps", type=int, default=5)
    ap.add_argument("--task", choices=("fixate", "search"), default="search")
    ap.add_argument("--resets", type=float, default=0.1, help="fraction of worlds reset per step (default 0.1)")
    ap.add_argument("--baseline-envs", type=int, default=64, help="worlds in the per-world baseline (default 64)")
    args = ap.parse_args(argv)
    task = TASKS[args.task]()
    base = baseline(task, args.baseline_envs, args.steps, args.resets)
    print(
        f"host side on {cpu_name()} ({os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}), task "
        f"{args.task}, {args.resets:.0%} of worlds reset per step, numba threads {numba.get_num_threads()}; "
        f"baseline: {args.baseline_envs} worlds of models.Head + SaccadePlan"
    )
    print(
        "\n| worlds | per-world objects us/world | batched planner us/world | speed-up | host ms per step | "
        + " | ".join(f"{p} us/world" for p in PARTS)
        + " |"
    )
    print("|---|---|---|---|---|" + "---|" * len(PARTS))
    for n in args.num_envs:
        parts: dict = {}
        b = batched(task, n, args.steps, args.resets, parts)
        print(
            f"| {n} | {base * 1e6:.0f} | {b * 1e6:.1f} | {base / b:.0f}x | {b * n * 1e3:.1f} | "
            + " | ".join(f"{parts[p] * 1e6:.1f}" for p in PARTS)
            + " |",
            flush=True,
        )
    print("target: <= 5 us per world and step (issue 38); parts timed separately: they add up to the total")
    print(
        "\nThe command tables and eye-position signals by the general kernels and by the fast ones, in this "
        "process (median of 5 calls per step's plans):\n\n| worlds | part | general us/world | fast us/world | "
        "speed-up | every bit the same |\n|---|---|---|---|---|---|"
    )
    for n in args.num_envs:
        for part, (g, f, same) in paths(task, n, args.steps).items():
            print(
                f"| {n} | {part} | {g * 1e6:.1f} | {f * 1e6:.1f} | {g / f:.2f}x | {'yes' if same else 'NO'} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
