"""Batched env steps per second (``envs.BatchedBinocularSaccade``), per part, beside the single CPU env.

For each number of worlds: env-steps/s (worlds x steps / s), the time of each part of a step
(host: action decoding and the saccade plans; remap: the remapping predictions; physics: MuJoCo
Warp; render: MJWarp's batch renderer, both eyes; retina: pooling; dpft; task: gaze errors and
scores; host sync: the clocks, the eye-position signals and the observations), and the device
memory (CUDA: the device's memory in use after the run, and torch's peak; CPU: the process's peak RSS). The single CPU
env (``BinocularSaccadeEnv``, the classic renderer) runs the same actions in the same process first.

    python benchmarks/batched.py                              # CUDA if Warp finds it, else the CPU backend
    python benchmarks/batched.py --device cpu --num-envs 1 4 16 --steps 3
    python benchmarks/batched.py --device cuda --num-envs 1 64 1024 4096 --image-size 128
    python benchmarks/batched.py --device cuda --retina-rays 1    # the retina rendered along its rays
    python benchmarks/batched.py --device cuda --linear-tail on   # the slow stretch in closed form on CUDA
    python benchmarks/batched.py --device cuda --fused on         # the physics in one kernel per step
    python benchmarks/batched.py --device cuda --csv out.csv --label "branch x"   # the table as CSV

The README's tables are rendered from such CSVs in ``benchmarks/data/`` by ``benchmarks/tables.py``.

Each configuration is warmed up (kernel compilation, graph capture) before it is timed.
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np

import envs

PARTS = ("host", "remap", "physics", "render", "retina", "dpft", "task", "host sync")


def _actions(rng: np.random.Generator, n: int) -> np.ndarray:
    return rng.uniform(-0.4, 0.4, size=(n, 2)).astype(np.float32)


def single_env(args) -> float:
    env = envs.BinocularSaccadeEnv(image_size=args.image_size)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(3):
        env.step(_actions(rng, 1)[0])
    t0, steps = time.perf_counter(), 0
    while steps < args.single_steps:
        _, _, te, tr, _ = env.step(_actions(rng, 1)[0])
        steps += 1
        if te or tr:
            env.reset()
    env.close()
    return steps / (time.perf_counter() - t0)


def batched(args, n: int) -> dict:
    import torch

    env = envs.BatchedBinocularSaccade(
        n,
        device=args.device,
        image_size=args.image_size,
        retina_rays=args.retina_rays,
        linear_tail={"auto": None, "on": True, "off": False}[args.linear_tail],
        fused_physics={"auto": None, "on": True, "off": False}[args.fused],
    )
    rng = np.random.default_rng(0)
    actions = [_actions(rng, n) for _ in range(args.steps)]
    env.reset(seed=0)
    for a in actions[:2]:  # compile, capture
        env.step(a)
    cuda = env.device.type == "cuda"
    dev = env.device
    sync = (lambda: torch.cuda.synchronize(dev)) if cuda else (lambda: None)
    if cuda:
        torch.cuda.reset_peak_memory_stats(dev)

    def run() -> float:  # the same episodes and actions each time: the same saccades and physics spans
        env.reset(seed=0)
        sync()
        t0 = time.perf_counter()
        for a in actions:
            env.step(a)
        sync()
        return time.perf_counter() - t0

    reruns = dict(env.physics.reruns)
    wall = run()  # steps/s without the per-part synchronisation
    reruns = {k: v - reruns[k] for k, v in env.physics.reruns.items()}
    env.timings = {}
    run()
    parts = {k: v / args.steps * 1e3 for k, v in env.timings.items()}
    env.timings = None
    wall = min(wall, run())
    if cuda:  # everything on the device (Warp's arrays and graphs, torch's tensors, both contexts)
        free, total = torch.cuda.mem_get_info(env.device)
        mem = f"{(total - free) / 2**20:.0f} MiB in use on the device ({torch.cuda.max_memory_allocated(dev) / 2**20:.0f} MiB torch peak)"
    else:
        mem = f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**10:.0f} MiB RSS (process)"
    env.close()
    return {
        "steps/s": n * args.steps / wall,
        "ms/step": wall / args.steps * 1e3,
        "parts": parts,
        "memory": mem,
        "reruns": reruns,
    }


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--device", default=None, help="cuda, cuda:<i> or cpu (default: cuda if available)")
    ap.add_argument(
        "--num-envs",
        type=int,
        nargs="+",
        default=None,
        help="worlds per configuration (default: 1 64 1024 4096 on CUDA, 1 4 16 on the CPU)",
    )
    ap.add_argument("--image-size", type=int, default=128)
    ap.add_argument("--steps", type=int, default=None, help="timed steps per configuration (default 20 CUDA, 3 CPU)")
    ap.add_argument("--single-steps", type=int, default=20)
    ap.add_argument(
        "--csv",
        default=None,
        help="also write the table to this CSV file (one row per number of worlds, the device named in each row)",
    )
    ap.add_argument(
        "--label",
        default=None,
        help="with --csv: what was measured (a branch, a commit), written "
        "in a first column 'code' (benchmarks/tables.py shows it)",
    )
    ap.add_argument(
        "--retina-rays",
        type=int,
        default=None,
        help="render the retina along s x s rays per receptive field (envs.retina_rays) instead of "
        "pinhole pictures (default: pictures)",
    )
    ap.add_argument(
        "--linear-tail",
        choices=("auto", "on", "off"),
        default="auto",
        help="the slow stretch of each step's physics in closed form (models.linear_tail): auto (the env's "
        "default: on for Warp's CPU backend, off on CUDA), on or off",
    )
    ap.add_argument(
        "--fused",
        choices=("auto", "on", "off"),
        default="auto",
        help="each step's physics in one kernel launch (envs._warp_dynamics): auto (the env's default: on "
        "for Warp's CPU backend, off on CUDA), on or off",
    )
    args = ap.parse_args(argv)
    import torch
    import warp as wp

    if args.device is None:  # as the env resolves it: CUDA needs both Warp's and torch's
        args.device = "cuda" if wp.is_cuda_available() and torch.cuda.is_available() else "cpu"
    cpu = args.device == "cpu"
    args.num_envs = args.num_envs or ([1, 4, 16] if cpu else [1, 64, 1024, 4096])
    args.steps = args.steps or (3 if cpu else 20)
    device_name = "CPU backend" if cpu else wp.get_device(args.device).name
    seen = (
        f"{args.image_size} px per eye"
        if args.retina_rays is None
        else f"retina rays ({args.retina_rays}x{args.retina_rays} per field; the single env: {args.image_size} px)"
    )
    print(
        f"device: {args.device} ({device_name}); {seen}; dots scene, fixate task; linear tail {args.linear_tail}; fused {args.fused}"
    )
    single = single_env(args)
    print(
        f"single CPU env (BinocularSaccadeEnv, classic renderer): {single:.0f} steps/s (it simulates the whole "
        "250 ms fixation; the batched env simulates settle_ms = 20 ms past the last world's saccade and keeps "
        "the rest as a clock: the x single column compares the same env steps, not the same physics)"
    )
    rows = []
    for n in args.num_envs:
        r = batched(args, n)
        rows.append((n, r))
        rr = r["reruns"]
        print(
            f"  {n} worlds: {r['steps/s']:.0f} env-steps/s; physics stepped again with the solver in "
            f"{rr['whole']} of {args.steps} steps whole, {rr['closed_form']} from the closed form's start",
            flush=True,
        )
    head = ["worlds", "env-steps/s", "x single", "ms/step"] + [f"{p} ms" for p in PARTS] + ["memory"]
    print("\n| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for n, r in rows:
        cells = [str(n), f"{r['steps/s']:.0f}", f"{r['steps/s'] / single:.2f}", f"{r['ms/step']:.1f}"]
        cells += [f"{r['parts'].get(p, 0.0):.2f}" for p in PARTS] + [r["memory"]]
        print("| " + " | ".join(cells) + " |")
    if args.csv:
        from experiments.folders import write_csv

        fields = (["code"] if args.label else []) + [
            "device",
            "eyes",
            "worlds",
            "env_steps_per_s",
            "single_env_steps_per_s",
            "ms_per_step",
        ]
        fields += [f"{p.replace(' ', '_')}_ms" for p in PARTS] + ["memory"]
        write_csv(
            args.csv,
            fields,
            [
                {
                    **({"code": args.label} if args.label else {}),
                    "device": device_name,
                    "eyes": seen,
                    "worlds": n,
                    "env_steps_per_s": round(r["steps/s"], 1),
                    "single_env_steps_per_s": round(single, 1),
                    "ms_per_step": round(r["ms/step"], 3),
                    **{f"{p.replace(' ', '_')}_ms": round(r["parts"].get(p, 0.0), 3) for p in PARTS},
                    "memory": r["memory"],
                }
                for n, r in rows
            ],
        )


if __name__ == "__main__":
    main()
