"""The batched env's physics per env step: how many 1 ms physics steps it costs, what bounds them, the
constraint solver's share and the fused step's (``envs.batched_physics.WarpHeads``: ``skip_solver``,
``fused``).

The env's own physics runs are recorded (state, command tables, milliseconds) over a few steps of
random saccades, then replayed on fresh ``WarpHeads`` in the same process: MuJoCo Warp's ``step``
with its constraint solver, MuJoCo Warp without it (``skip_solver``; on the CPU backend with the slow
stretch in closed form, its default there), and the fused kernel (one launch per run,
``envs._warp_dynamics``). Printed: wall time per physics step (the ratios are the claim), kernel
launches per physics step (the launches over a non-empty grid, counted; on a GPU a step is
launch-bound) and the largest difference of the eye angles from the solver's run (issue 38: within
1e-4 deg).

    python benchmarks/physics.py --device cpu --num-envs 16 --steps 4
    python benchmarks/physics.py --device cuda --num-envs 1024 4096 --reference-worlds 16
"""

from __future__ import annotations

import argparse
import time
from unittest import mock

import numpy as np

import envs


def record(n: int, device: str, steps: int, seed: int = 0) -> tuple[envs.BatchedBinocularSaccade, list[dict]]:
    """A batched env of n worlds (16 px eyes) and its physics runs over ``steps`` random saccades:
    each run's starting state, command tables, lengths and milliseconds, and the plans' spans."""
    env = envs.BatchedBinocularSaccade(n, device=device, image_size=16)
    ph, runs = env.physics, []
    run = ph.run

    def recording(commands, lengths, n_ms, wait=True):
        state = [t.detach().clone() for t in (ph.qpos, ph.qvel, ph.ctrl, ph.mocap_pos, ph.mocap_quat)]
        runs.append({"state": state, "commands": np.array(commands), "lengths": np.array(lengths), "n_ms": n_ms})
        return run(commands, lengths, n_ms, wait=wait)

    with mock.patch.object(ph, "run", recording):
        env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        for _ in range(steps):
            env.step(rng.uniform(-0.4, 0.4, size=(n, 2)).astype(np.float32))
    return env, runs


def replay(env, runs: list[dict], **options) -> dict:
    """Each recorded run again on a fresh WarpHeads (``options``: its ``skip_solver``, ``fused``): seconds
    and launches per physics step, end eye angles."""
    import warp as wp

    from envs.batched_physics import WarpHeads

    ph = WarpHeads(env.head, env.num_envs, str(env.physics.device), chunk_ms=env.physics.chunk_ms, **options)
    launches = [0]
    launch = wp.launch

    def counting(kernel, dim, *args, **kwargs):  # Warp runs no kernel over an empty grid: not counted
        launches[0] += int(np.prod(dim)) > 0
        return launch(kernel, dim, *args, **kwargs)

    def once(r, count: bool):
        ph.load(np.arange(env.num_envs), *(t.cpu().numpy() for t in r["state"]))
        wp.launch = counting if count else launch
        try:
            t0 = time.perf_counter()
            ph.run(r["commands"], r["lengths"], r["n_ms"])
            return time.perf_counter() - t0
        finally:
            wp.launch = launch

    once(runs[0], False)  # compile, capture
    wall, eyes, ms = 0.0, [], 0
    for r in runs:
        wall += once(r, False)
        ms += r["n_ms"]
        eyes.append(ph.eye_qpos().double().cpu().numpy())
        if "table" not in r:  # the set-points as the device holds them (float32)
            r["table"] = ph.setpoints(r["commands"], r["lengths"]).float().double().cpu().numpy()
    if ph.device.is_cuda:  # Warp's launches are counted as they are issued: the graph's, without replay
        launches[0] = -1
    else:
        launches[0] = 0
        once(runs[0], True)
    return {
        "s_per_ms": wall / ms,
        "launches_per_ms": launches[0] / runs[0]["n_ms"] if launches[0] >= 0 else None,
        "eyes": eyes,
    }


def reference(env, runs: list[dict], worlds: int) -> list[np.ndarray]:
    """Each recorded run's first ``worlds`` worlds stepped by MuJoCo's C ``mj_step`` in float64
    (``envs.batched_physics.mujoco_replay``): the eyes' angles (worlds, 2, 3) after each."""
    from envs.batched_physics import mujoco_replay

    qadr = np.asarray(env.head.eye_joint_addresses[0])
    out = []
    for r in runs:
        qpos, qvel, ctrl = (t.double().cpu().numpy()[:worlds] for t in r["state"][:3])
        q = mujoco_replay(env.head, qpos, qvel, ctrl, r["table"], r["lengths"], r["n_ms"])
        out.append(q[:, qadr].reshape(-1, 2, 3))
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--num-envs", type=int, nargs="+", default=[16])
    ap.add_argument("--steps", type=int, default=4)
    ap.add_argument(
        "--reference-worlds",
        type=int,
        default=64,
        help="the first K worlds are also stepped by MuJoCo's C mj_step in float64 (default 64; it runs on one core)",
    )
    args = ap.parse_args(argv)
    for n in args.num_envs:
        env, runs = record(n, args.device, args.steps)
        spans = [r["lengths"] for r in runs]
        print(
            f"{n} worlds on {env.physics.device}: physics ms per env step "
            + ", ".join(str(r["n_ms"]) for r in runs)
            + f" (the slowest world's plan + settle_ms {env.settle_ms}; the worlds' plans: mean "
            f"{np.mean([s.mean() for s in spans]):.0f} ms, slowest {max(s.max() for s in spans)} ms)"
        )
        full = replay(env, runs, skip_solver=False, fused=False)
        k = min(n, args.reference_worlds)
        exact = reference(env, runs, k)
        rows = (
            ("MuJoCo Warp with the solver", full),
            ("MuJoCo Warp without it (skip_solver)", replay(env, runs, skip_solver=True, fused=False)),
            ("fused (one kernel per run)", replay(env, runs, fused=True)),
        )
        print(
            "\n| physics | ms per physics step | launches per physics step | speed-up | largest eye difference "
            f"from the solver's run, deg | from MuJoCo C (float64), deg (the first {k} worlds) |"
        )
        print("|---|---|---|---|---|---|")
        for name, r in rows:
            lpm = "n/a (CUDA graph)" if r["launches_per_ms"] is None else f"{r['launches_per_ms']:.2f}"
            diff = max(np.degrees(np.abs(a - b)).max() for a, b in zip(full["eyes"], r["eyes"]))
            c = max(np.degrees(np.abs(a - b[:k])).max() for a, b in zip(exact, r["eyes"]))
            print(
                f"| {name} | {r['s_per_ms'] * 1e3:.3f} | {lpm} | {full['s_per_ms'] / r['s_per_ms']:.1f}x | "
                f"{diff:.1e} | {c:.1e} |"
            )
        print("(issue 38: the eyes within 1e-4 deg of the solver's run)")
        env.close()


if __name__ == "__main__":
    main()
