"""A recorded run of ``envs.BinocularSaccadeEnv``: :func:`record_env_run`."""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

from ..cli.progress import Progress, stage
from .recorder import Recorder


def _angles_deg(z: complex) -> tuple[float, float]:
    """Image-plane point -> (azimuth_deg, elevation_deg) in that eye's frame."""
    return math.degrees(math.atan(z.real)), math.degrees(math.atan2(z.imag, math.hypot(1.0, z.real)))


def _choose_target(head, rng: np.random.Generator, previous: str | None) -> str | None:
    flashes = set(head.scene.flashes)
    names = [n for n in head.scene.objects if n not in flashes and n != previous]
    if "target" in names and previous != "target" and rng.random() < 0.5:
        return "target"
    return str(rng.choice(names)) if names else None


def record_env_run(
    path: str | os.PathLike | None,
    *,
    steps: int = 4,
    seed: int = 0,
    task: str = "fixate",
    scene: str | None = None,
    image_size: int = 128,
    fixation_ms: int = 250,
    latency_ms: int = 40,
    flash_lead_ms: int = 20,
    shift_rings: float = 2.0,
    remap_model: str = "homography",
    spawn: bool = False,
    connect: str | None = None,
    recording_id: str | None = None,
    progress: bool = False,
) -> dict[str, Any]:
    """Record ``steps`` saccades of ``envs.BinocularSaccadeEnv`` (one env step each, driven through
    ``env.head`` and ``env.vision`` to see inside the saccade).

    Each step: plan a saccade (with ``latency_ms``): even steps to a scene object chosen at random
    (the task's target half the time), odd steps 3-20 deg in a random direction; predict both eyes'
    post-saccadic samples with every remapping model from the pre-saccadic DPFT and the efference
    copy; step the physics 1 ms at a time through the saccade, logging the eye trace (every physics
    step) and the 3-D scene, head and eye cameras each ms; in the ``dots`` scene flash a random
    flash ``flash_lead_ms`` before onset (images logged at that instant) and log its true and
    perceived position; then ``fixation_ms`` of fixation, render, and log images, retina, DPFT,
    cortex and the remapping (model ``remap_model``) with the models' errors. Images are logged
    only at reset, the flash and the end of each fixation. Timelines: ``sim_time``, and ``episode``
    (0) and ``env_step`` (0 at reset, k for everything logged during the k-th saccade and its fixation).

    The perceived flash is an illustration of §6.5's remapping by the log-radius shift, not a
    fitted model: the flash's pre-saccadic image point z in the left eye is compressed towards the
    saccade target z_t, z_t + e^{-shift_rings delta} (z - z_t); both are reported as the left
    eye's pre-saccadic (azimuth, elevation). Returns a summary (times, saccades, errors).

    ``path``, ``spawn`` and ``connect`` are :class:`Recorder`'s (a file, a native viewer, a running
    viewer or proxy such as :class:`WebViewer`).
    """
    import envs  # heavy (MuJoCo): imported on use
    import models

    if int(steps) != steps or steps < 1:
        raise ValueError(f"steps must be a positive integer; got {steps!r}")
    if remap_model not in envs.REMAP_MODELS:
        raise ValueError(f"remap_model must be one of {envs.REMAP_MODELS}; got {remap_model!r}")
    if int(latency_ms) != latency_ms or not 0 <= flash_lead_ms <= latency_ms:
        raise ValueError("need whole latency_ms >= flash_lead_ms >= 0")
    stage(
        f"recording: building the head and the {'default' if scene is None else repr(scene)} scene, first render",
        enabled=progress,
    )
    env = envs.BinocularSaccadeEnv(
        scene=scene, task=task, image_size=image_size, fixation_ms=fixation_ms, shift_rings=shift_rings
    )
    rng = np.random.default_rng(seed)
    summary: dict[str, Any] = {"start_ms": None, "end_ms": None, "saccades": [], "remap_error": []}
    try:
        with Recorder(path, spawn=spawn, connect=connect, recording_id=recording_id) as rec:
            env.reset(seed=seed)
            head, vision, grid = env.head, env.vision, env.vision.grid
            has_target = "target" in head.scene.objects

            def log_images(views, frame) -> None:
                tp = head.project_to_pixels(head.object_position("target")) if has_target else None
                rec.log_frame(frame, grid, tp)
                rec.log_views(views, grid)

            def look():
                frame = head.render()
                return frame, (vision.see(frame.left.image), vision.see(frame.right.image))

            summary["start_ms"] = float(head.time_ms)
            rec.set_time("episode", 0)  # one episode; env_step k: what happened during the k-th saccade
            rec.set_time("env_step", 0)
            rec.set_time_ms(head.time_ms)
            frame, views = look()
            rec.log_head(head)
            log_images(views, frame)
            rec.log_eye_angles(head.eye_angles, np.zeros((2, 3)), head.eye_position_signal())
            previous = None
            bar = Progress(
                int(steps),
                unit="saccade",
                desc="recording",
                enabled=progress,
                warmup="first saccade (compiling numba kernels on a first run)",
            )
            for step in range(int(steps)):
                rec.set_time("env_step", step + 1)
                # alternate object saccades with random ones of 3-20 deg (the main sequence's range)
                name = _choose_target(head, rng, previous) if step % 2 == 0 else None
                plan = None
                if name is not None:
                    try:
                        plan = head.plan_saccade_to(name, latency_ms=latency_ms)
                        previous = name
                    except models.OculomotorRangeError:
                        plan = None
                while plan is None:
                    amp, direction = np.radians(rng.uniform(3.0, 20.0)), rng.uniform(0.0, 2 * np.pi)
                    try:
                        plan = head.plan_saccade(
                            amp * math.cos(direction), amp * math.sin(direction), latency_ms=latency_ms
                        )
                    except models.OculomotorRangeError:
                        plan = None
                R = plan.efference_copy_eye
                preds = vision.predict_eyes(views, envs.REMAP_MODELS, R)
                flash_ms = plan.onset_ms - int(flash_lead_ms) if head.scene.flashes else None
                z_pre = head.eye_states()[0]
                traces = []
                head.start_saccade(plan)
                rec.log_saccade(plan)
                while head.time_ms < plan.end_ms:
                    if flash_ms is not None and head.time_ms == flash_ms:
                        fname = str(rng.choice(head.scene.flashes))
                        head.flash(fname, duration_ms=8)
                        rec.set_time_ms(head.time_ms)
                        rec.log_head(head)
                        f_frame, f_views = look()
                        log_images(f_views, f_frame)
                        zf = complex(z_pre.project(head.object_position(fname)[None])[0])
                        zt = complex(z_pre.project(np.asarray(plan.intended_target)[None])[0])
                        zp = zt + math.exp(-shift_rings * grid.delta) * (zf - zt)
                        rec.log_flash(_angles_deg(zf), _angles_deg(zp), _angles_deg(zt))
                    traces.append(head.step_ms(1, record=True))
                    rec.set_time_ms(head.time_ms)
                    rec.log_head(head)
                traces.append(head.step_ms(int(fixation_ms), record=True))
                rec.log_eye_trace(
                    models.EyeTrace.concatenate(traces)
                )  # one batch per step: thousands of 1 ms batches load slowly
                traces.clear()
                rec.set_time_ms(head.time_ms)
                rec.log_head(head)
                frame, new_views = look()
                errors = envs.model_errors(preds, new_views)
                log_images(new_views, frame)
                rec.log_remap((preds[0][remap_model], preds[1][remap_model]), new_views, grid, errors)
                views = new_views
                summary["saccades"].append(
                    {
                        "onset_ms": plan.onset_ms,
                        "amplitude_deg": plan.amplitude_deg,
                        "peak_velocity_deg_s": math.degrees(plan.peak_velocity),
                        "duration_ms": plan.duration_ms,
                    }
                )
                summary["remap_error"].append(errors)
                bar.update()
            bar.close()
            summary["end_ms"] = float(head.time_ms)
    finally:
        env.close()
    return summary
