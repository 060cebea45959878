"""Remapping predictions: point samples of the series vs averages over each receptive field.

The env predicts each eye's post-saccadic retina from the pre-saccadic DPFT coefficients and the
efference copy. The plain prediction is the series at each new receptive field's centre; the
pooled one (``pooled_remap=True``, ``conformal.RemapPlan``'s ``pooled``) averages it over the
field, as the retina's ``"pool"`` sampling averages the picture. This prints

1. the normalized RMS error (``info["remap_error"]``, mean of both eyes) of each model, point vs
   pooled, for horizontal saccades of +-amplitude from straight ahead (outward) and the saccade
   back (return), in the ``bar`` scene (``--scenes`` for others);
2. the cost per env step of the predictions (both eyes, all three models, and homography alone);
3. the env's time per step with each, beside the bare MuJoCo loop of ``benchmarks/env.py``
   (the target there: the default env at most 1.3x the bare loop).

    python benchmarks/remap_pooling.py [--scenes bar natural] [--amplitudes 20 10] [--steps 200] [--repeats 5]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from env import SACCADE, bare_loop, env_loop  # benchmarks/env.py

import envs
from models import plan_clipped


def errors(scene: str, amplitude_deg: float) -> dict[str, dict[str, dict[str, float]]]:
    """{leg: {model: {"point", "pooled"}}} for the saccade +amplitude and back, then -amplitude and back."""
    envs_ = {
        p: envs.BinocularSaccadeEnv(scene=scene, task="free", image_size=128, pooled_remap=p) for p in (False, True)
    }
    out: dict[str, dict[str, dict[str, float]]] = {}
    for sign, side in ((1, "right"), (-1, "left")):
        for e in envs_.values():
            e.reset(seed=0)
        for leg, a in (("outward", sign * amplitude_deg), ("return", -sign * amplitude_deg)):
            action = np.array([a / 30.0, 0.0], np.float32)
            obs = {}
            for p, e in envs_.items():
                o, _, _, _, info = e.step(action)
                obs[p] = o["cortical"]
                for m, err in info["remap_error"].items():
                    out.setdefault(f"{side} {leg}", {}).setdefault(m, {})["pooled" if p else "point"] = err
            assert np.array_equal(obs[False], obs[True]), "pooling must change the prediction only"
    for e in envs_.values():
        e.close()
    return out


def prediction_cost(models: tuple[str, ...], repeats: int = 300) -> dict[bool, float]:
    """Seconds per call of the env's prediction (both eyes, ``models``), point and pooled."""
    e = envs.BinocularSaccadeEnv(scene="bar", task="free", image_size=128)
    e.reset(seed=0)
    plan, _ = plan_clipped(e.head, 0.3 * e.max_amplitude, 0.1 * e.max_amplitude, 1.0)
    v = e.vision
    kinds, params = v.map_params(models, plan.efference_copy_eye)
    frame = e.seen
    best: dict = {}
    for pooled in (False, True):
        v.plan.evaluate_prechecked(frame.coeffs, frame.fovea, kinds, params, pooled)  # compile / warm up
    for pooled in (False, True, False, True):
        t0 = time.perf_counter()
        for _ in range(repeats):
            v.plan.evaluate_prechecked(frame.coeffs, frame.fovea, kinds, params, pooled)
        best[pooled] = min(best.get(pooled, np.inf), (time.perf_counter() - t0) / repeats)
    e.close()
    return best


def env_speed(steps: int, repeats: int) -> dict[str, np.ndarray]:
    """Seconds per step of the default env with pooling off and on, and of the bare loop, alternating."""
    actions = np.tile(SACCADE, (steps // 2, 1))
    runs = {
        "point": envs.BinocularSaccadeEnv(image_size=128),
        "pooled": envs.BinocularSaccadeEnv(image_size=128, pooled_remap=True),
    }
    for e in runs.values():
        e.reset(seed=0)
        env_loop(e, actions[:20])  # warm-up
    head = runs["point"].head
    t: dict[str, list[float]] = {"point": [], "pooled": [], "bare": []}
    for _ in range(repeats):
        for name, e in runs.items():
            e.reset(seed=0)
            t[name].append(env_loop(e, actions) / len(actions))
        head.reset(seed=0)
        t["bare"].append(bare_loop(head, actions, runs["point"].fixation_ms) / len(actions))
    for e in runs.values():
        e.close()
    return {k: np.array(v) for k, v in t.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=["bar"], help="scenes for the error table (default: bar)")
    ap.add_argument(
        "--amplitudes",
        nargs="+",
        type=float,
        default=[20.0],
        help="horizontal saccade amplitudes, deg, in (0, 30] (default: 20)",
    )
    ap.add_argument("--steps", type=int, default=200, help="env steps per timed run (default 200)")
    ap.add_argument("--repeats", type=int, default=5, help="timed runs, alternating (default 5)")
    ap.add_argument("--skip-speed", action="store_true", help="only the error table")
    args = ap.parse_args()
    if args.steps < 2 or args.repeats < 1:
        ap.error("--steps must be >= 2 and --repeats >= 1")
    if any(not 0 < a <= 30 for a in args.amplitudes):
        ap.error("--amplitudes must lie in (0, 30] deg")

    print("normalized RMS error of the predicted post-saccadic retina (info['remap_error'], mean of both eyes);")
    print("outward: from straight ahead; return: the saccade back")
    print(f"{'scene':8s} {'saccade':>8s} {'leg':15s} {'model':11s} {'point':>7s} {'pooled':>7s} {'change':>7s}")
    for scene in args.scenes:
        for amp in args.amplitudes:
            for leg, per_model in errors(scene, amp).items():
                for m, r in per_model.items():
                    print(
                        f"{scene:8s} {amp:6.0f}deg {leg:15s} {m:11s} {r['point']:7.3f} {r['pooled']:7.3f} "
                        f"{r['pooled'] / r['point'] - 1:+6.0%}"
                    )
    if args.skip_speed:
        return

    print("\ncost of the predictions per env step (both eyes, 128x128 images; best of 2 x 300 calls)")
    print(f"{'models':28s} {'point ms':>9s} {'pooled ms':>10s} {'ratio':>6s}")
    for models in (envs.REMAP_MODELS, ("homography",)):
        c = prediction_cost(models)
        print(f"{', '.join(models):28s} {c[False] * 1e3:9.3f} {c[True] * 1e3:10.3f} {c[True] / c[False]:5.2f}x")

    t = env_speed(args.steps, args.repeats)
    print(f"\nenv steps (default config otherwise, all 3 models), {args.steps} steps, {args.repeats} alternating runs")
    print(f"{'configuration':28s} {'ms/step':>8s} {'steps/s':>8s} {'env/bare':>9s} {'run to run':>11s}")
    for name in ("point", "pooled", "bare"):
        ratios = t[name] / t["bare"]
        label = {"point": "env, pooled_remap=False", "pooled": "env, pooled_remap=True", "bare": "bare MuJoCo loop"}
        best = t[name].min()
        print(
            f"{label[name]:28s} {best * 1e3:8.2f} {1 / best:8.0f} {best / t['bare'].min():8.2f}x "
            f"{ratios.min():5.2f}-{ratios.max():.2f}x"
        )
    print("ms/step, steps/s and env/bare from the best run of each; run to run: each run over the bare run beside it")


if __name__ == "__main__":
    main()
