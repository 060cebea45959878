"""Cost of rendering both eyes (128, 256, 512 px; fast and default quality) beside the physics:
300 ms of fixation, one 10 deg saccade + 250 ms of fixation (one RL step of simulated time) and
one physics step. Prints a table; never used as a timed assertion.

    python benchmarks/render.py [--scene dots] [--repeats 30]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

try:
    import models
except ImportError:  # running from a checkout without `pip install -e .`
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    import models
import mujoco  # after models: importing models picks MuJoCo's off-screen GL backend first


def _time(fn, repeats: int) -> float:
    fn()  # warm-up
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return float(np.median(ts)) * 1e3


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scene", default="dots", choices=models.SCENES)
    ap.add_argument("--repeats", type=int, default=30)
    args = ap.parse_args()
    rows = []
    for quality in models.QUALITIES:
        for size in (128, 256, 512):
            with models.Head(args.scene, image_size=size, quality=quality) as head:
                rows.append((f"render both eyes {size}x{size}", quality, _time(head.render, args.repeats)))
    head = models.Head(args.scene, image_size=16)
    rows.append(
        (
            f"physics: 300 ms fixation ({models.DEFAULT_TIMESTEP_MS:g} ms step)",
            "-",
            _time(lambda: head.step_ms(300), args.repeats),
        )
    )

    def saccade_and_fixation():
        head.reset(settle_ms=0)  # excluded below: timed from the plan on
        plan = head.plan_saccade(np.deg2rad(10), 0.0)
        head.start_saccade(plan)
        t0 = time.perf_counter()
        head.step_ms(plan.end_ms - head.time_ms + 250)
        return time.perf_counter() - t0

    saccade_and_fixation()
    ts = [saccade_and_fixation() for _ in range(args.repeats)]
    rows.append(
        (
            f"physics: 10 deg saccade + 250 ms ({models.DEFAULT_SACCADE_TIMESTEP_MS:g} ms step)",
            "-",
            float(np.median(ts)) * 1e3,
        )
    )
    model = models.build_model(args.scene)  # the head's MuJoCo model, stepped bare at the fixation step
    model.opt.timestep = models.DEFAULT_TIMESTEP_MS * 1e-3
    data = mujoco.MjData(model)
    rows.append(("physics: one mj_step", "-", _time(lambda: mujoco.mj_step(model, data), args.repeats * 10)))
    print(f"scene={args.scene}  MUJOCO_GL={__import__('os').environ.get('MUJOCO_GL')}  (median ms)")
    print(f"{'operation':<48}{'quality':<10}{'ms':>10}")
    print("-" * 68)
    for name, q, ms in rows:
        print(f"{name:<48}{q:<10}{ms:>10.3f}")


if __name__ == "__main__":
    main()
