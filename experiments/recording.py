"""Rerun recordings of the whole pipeline on a timeline of simulated milliseconds.

:class:`Recorder` turns the project's objects (``models.Head``, ``StereoFrame``, ``envs.EyeView``,
``conformal.RetinaSamples``, ``models.EyeTrace``) into Rerun archetypes under a stable entity
tree; :func:`record_env_run` records a few saccades of ``envs.BinocularSaccadeEnv``; the
``visualize`` command (``python -m experiments visualize --out run.rrd`` or ``--spawn``) runs it.
The layout is :func:`experiments.blueprint.blueprint`, sent with the recording.

Timeline: ``sim_time`` (a duration; simulated time, seconds in Rerun = ms / 1000).

Entity tree (``{eye}`` is ``left`` or ``right``; images are uint8 RGB, or L for grayscale):

========================================  =====================================================
``world/head/origin``, ``world/head/axes``  head position; its forward (red), left (green), up (blue) axes (Points3D, Arrows3D)
``world/eyes/{eye}/position``              the eye's nodal point (Points3D)
``world/eyes/{eye}/gaze``                  the optical axis x2 as a ray of ``gaze_length`` m (Arrows3D)
``world/objects``                          the scene's named objects (Points3D with labels)
``world/flashes``                          flashes visible at that instant (Points3D; empty when none)
``eyes/{eye}/image``                       the rendered eye image (H, W, 3)
``eyes/{eye}/grid``                        retina grid overlay: ring circles and sector edges in pixels (LineStrips2D, static)
``eyes/{eye}/target``                      the saccade target's pixel position (Points2D)
``retina/{eye}/fovea``                     foveal samples on their P x P lattice (``conformal.fovea_image``)
``retina/{eye}/logpolar``                  peripheral samples (M, N) [ring, sector]
``dpft/{eye}/log_magnitude``               log(1 + abs(DPFT)) averaged over colour, (M, N) float32, zero frequency centred (fftshift)
``cortex/left_hemisphere``                 right hemifield of both eyes, (N/2, 2M): left eye | right eye, rows from the upper
                                           vertical meridian, eccentricity growing to the right within each half
``cortex/right_hemisphere``                left hemifield of both eyes, (N/2, 2M), same layout
``remap/{eye}/predicted``                  predicted post-saccadic cortical map of one eye (``conformal.cortical_map``, (N/2, 2M)); unknown cells 0
``remap/{eye}/actual``                     the rendered post-saccadic cortical map, (N/2, 2M)
``remap/{eye}/difference``                 abs(predicted - actual) (both clipped to [0, 1]) where both are valid, (N/2, 2M)
``remap/error/{model}``                    normalized RMS error of each remapping model (Scalars)
``flash/true``, ``flash/perceived``        flash positions (x = azimuth_deg, y = -elevation_deg: up is up in the 2-D view) (Points2D)
``flash/shift``                            arrow from true to perceived (Arrows2D)
``flash/target``, ``flash/fixation``       the saccade target, and the fixation point (0, 0) (static), same frame
``eyes/{eye}/angle/{h,v,t}``               Fick angles, deg (Scalars; h > 0 right, v > 0 up, t torsion)
``eyes/{eye}/velocity/{h,v,t}``            joint rates, deg/s (Scalars)
``saccades/{amplitude_deg,peak_velocity_deg_s,duration_ms}``  per saccade, at its onset (Scalars)
========================================  =====================================================
"""

from __future__ import annotations

import argparse
import math
import os
import uuid
from typing import Any, Sequence

import numpy as np
import rerun as rr

import conformal as C

from .blueprint import blueprint

__all__ = ["Recorder", "record_env_run", "add_subcommand", "EYE_NAMES", "AXIS_NAMES", "TIMELINE"]

EYE_NAMES = ("left", "right")
AXIS_NAMES = ("h", "v", "t")
TIMELINE = "sim_time"
_AXIS_COLORS = np.array([[220, 50, 50], [50, 180, 50], [60, 90, 230]], np.uint8)


def _to_uint8(a: np.ndarray) -> np.ndarray:
    """Intensities in [0, 1] -> uint8 image; a single channel becomes (H, W)."""
    a = np.asarray(a, dtype=float)
    if a.ndim == 3 and a.shape[-1] == 1:
        a = a[..., 0]
    return (np.clip(np.nan_to_num(a), 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def hemisphere_image(hemisphere: np.ndarray) -> np.ndarray:
    """(2, M, N/2[, C]) [eye, ring, sector] -> (N/2, 2M[, C]) picture: left eye | right eye."""
    h = np.asarray(hemisphere)
    return np.concatenate([np.swapaxes(h[0], 0, 1), np.swapaxes(h[1], 0, 1)], axis=1)


def grid_strips(grid: C.RetinaGrid, shape: tuple[int, int], pixels_per_unit: float,
                n_arc: int = 96) -> list[np.ndarray]:
    """Retina grid as 2-D line strips in Rerun pixel coordinates (x right, y down, pixel
    centres at +0.5): M + 1 ring circles (incl. the foveal edge r0) and N sector edges."""
    h, w = shape
    f = float(pixels_per_unit)
    radii = grid.r0 * np.exp(grid.delta * np.arange(grid.M + 1))
    t = np.linspace(0.0, 2 * np.pi, n_arc + 1)
    strips = [np.stack([w / 2 + r * f * np.cos(t), h / 2 - r * f * np.sin(t)], -1) for r in radii]
    for a in 2 * np.pi * np.arange(grid.N) / grid.N:
        r = np.array([radii[0], radii[-1]])
        strips.append(np.stack([w / 2 + r * f * np.cos(a), h / 2 - r * f * np.sin(a)], -1))
    return strips


class Recorder:
    """Log the pipeline to a Rerun recording (see the module docstring for the entity tree).

    ``path`` saves an ``.rrd`` file; ``spawn=True`` opens a viewer (both may be given).
    With neither, data is buffered in memory and dropped. Call :meth:`set_time_ms` before logging
    what belongs to an instant, and :meth:`close` at the end (or use it as a context manager).
    """

    def __init__(self, path: str | os.PathLike | None = None, *, spawn: bool = False,
                 app_id: str = "conformal_head", recording_id: str | None = None,
                 gaze_length: float = 1.0) -> None:
        if not app_id:
            raise ValueError("app_id must be a non-empty string")
        if not (math.isfinite(gaze_length) and gaze_length > 0):
            raise ValueError(f"gaze_length must be positive (metres); got {gaze_length!r}")
        self.path = None if path is None else os.fspath(path)
        self.gaze_length = float(gaze_length)
        rid = recording_id or str(uuid.uuid4())
        self.rec = rr.RecordingStream(app_id, recording_id=rid)
        bp = blueprint()
        if self.path is not None:
            os.makedirs(os.path.dirname(os.path.abspath(self.path)), exist_ok=True)
        if spawn:
            rr.spawn(connect=False, recording=self.rec)
            sinks = [rr.GrpcSink()]
            if self.path is not None:
                sinks.append(rr.FileSink(self.path))
            self.rec.set_sinks(*sinks, default_blueprint=bp)
        elif self.path is not None:
            self.rec.save(self.path, default_blueprint=bp)
        self.t_ms = 0.0
        self._grid_logged: set[str] = set()
        self._closed = False

    # ------------------------------------------------------------------ plumbing
    def __enter__(self) -> "Recorder":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def set_time_ms(self, t_ms: float) -> None:
        """Set the ``sim_time`` timeline to ``t_ms`` simulated milliseconds."""
        t = float(t_ms)
        if not math.isfinite(t):
            raise ValueError(f"t_ms must be finite; got {t_ms!r}")
        self.t_ms = t
        self.rec.set_time(TIMELINE, duration=t / 1000.0)

    def log(self, entity: str, archetype: Any, *, static: bool = False) -> None:
        """Log any Rerun archetype at the current time (escape hatch for other modules)."""
        self.rec.log(entity, archetype, static=static)

    def close(self) -> None:
        """Flush and close the recording (the ``.rrd`` file is complete afterwards)."""
        if self._closed:
            return
        self._closed = True
        self.rec.flush()
        self.rec.disconnect()

    # ------------------------------------------------------------------ 3-D
    def log_head(self, head) -> None:
        """Head pose and axes, eye positions, gaze rays, scene objects and visible flashes."""
        origin = head.to_world(np.zeros(3))
        axes = np.stack([head.to_world(np.eye(3)[i]) - origin for i in range(3)])
        self.rec.log("world/head/origin", rr.Points3D([origin], radii=0.01, colors=[[200, 200, 200]],
                                                      labels=["head"]))
        self.rec.log("world/head/axes", rr.Arrows3D(vectors=0.1 * axes, origins=np.repeat([origin], 3, 0),
                                                    colors=_AXIS_COLORS))
        for name, state in zip(EYE_NAMES, head.eye_states()):
            p = np.asarray(state.camera_position, float)
            gaze = np.asarray(state.eye_axes, float)[:, 1] * self.gaze_length
            color = [[60, 120, 255]] if name == "left" else [[255, 120, 60]]
            self.rec.log(f"world/eyes/{name}/position", rr.Points3D([p], radii=0.012, colors=color))
            self.rec.log(f"world/eyes/{name}/gaze", rr.Arrows3D(vectors=[gaze], origins=[p], colors=color))
        flashes = set(head.scene.flashes)
        names = [n for n in head.scene.objects if n not in flashes]
        if names:
            pos = np.stack([head.object_position(n) for n in names])
            colors = [[255, 60, 60] if n == "target" else [230, 230, 230] for n in names]
            self.rec.log("world/objects", rr.Points3D(pos, radii=0.01, labels=names, colors=colors))
        visible = list(head.visible_flashes)
        pos = np.stack([head.object_position(n) for n in visible]) if visible else np.zeros((0, 3))
        self.rec.log("world/flashes", rr.Points3D(pos, radii=0.015, colors=[[255, 255, 0]] * len(visible)))

    # ------------------------------------------------------------------ images
    def log_frame(self, frame, grid: C.RetinaGrid, target_px=None) -> None:
        """Both eyes' images; the retina grid overlay (logged once per eye, static); the target.

        ``target_px``: (2, 2) [eye, (row, col)] as from ``Head.project_to_pixels`` (pixel centres
        at integers), or (2, 1, 2) of that, or None.
        """
        tp = None if target_px is None else np.asarray(target_px, float).reshape(2, -1, 2)
        for i, (name, eye) in enumerate(zip(EYE_NAMES, (frame.left, frame.right))):
            img = np.asarray(eye.image)
            self.rec.log(f"eyes/{name}/image", rr.Image(img))
            if name not in self._grid_logged:
                strips = grid_strips(grid, img.shape[:2], eye.pixels_per_unit)
                self.rec.log(f"eyes/{name}/grid", rr.LineStrips2D(strips, colors=[[0, 200, 200, 110]], radii=0.25),
                             static=True)
                self._grid_logged.add(name)
            if tp is not None:
                xy = np.stack([tp[i, :, 1] + 0.5, tp[i, :, 0] + 0.5], -1)
                self.rec.log(f"eyes/{name}/target", rr.Points2D(xy, radii=2.5, colors=[[255, 40, 40]]))

    def log_views(self, views, grid: C.RetinaGrid) -> None:
        """Foveal and log-polar samples, the DPFT log-magnitude of each eye, both hemispheres."""
        for name, v in zip(EYE_NAMES, views):
            self.rec.log(f"retina/{name}/fovea", rr.Image(_to_uint8(C.fovea_image(v.fovea, grid))))
            self.rec.log(f"retina/{name}/logpolar", rr.Image(_to_uint8(v.periphery)))
            mag = np.log1p(np.abs(np.asarray(v.coeffs)))
            if mag.ndim == 3:
                mag = mag.mean(axis=-1)
            self.rec.log(f"dpft/{name}/log_magnitude", rr.Image(np.fft.fftshift(mag).astype(np.float32)))
        bc = C.binocular_cortex(views[0].periphery, views[1].periphery, grid)
        self.rec.log("cortex/left_hemisphere", rr.Image(_to_uint8(hemisphere_image(bc.left_hemisphere))))
        self.rec.log("cortex/right_hemisphere", rr.Image(_to_uint8(hemisphere_image(bc.right_hemisphere))))

    def log_remap(self, predicted, actual, grid: C.RetinaGrid, errors: dict[str, float] | None = None) -> None:
        """Predicted (from the pre-saccadic DPFT and the efference copy) vs actual post-saccadic
        cortical maps of each eye and their absolute difference; optional per-model errors."""
        for name, p, a in zip(EYE_NAMES, predicted, actual):
            pm = np.asarray(p.mask, bool)[..., None]
            both = pm & np.asarray(a.mask, bool)[..., None]
            pred = np.where(pm, np.clip(p.periphery, 0.0, 1.0), 0.0)  # as the env's ``remapped``
            diff = np.where(both, np.abs(pred - np.clip(a.periphery, 0.0, 1.0)), 0.0)
            self.rec.log(f"remap/{name}/predicted", rr.Image(_to_uint8(C.cortical_map(pred, grid))))
            self.rec.log(f"remap/{name}/actual", rr.Image(_to_uint8(C.cortical_map(a.periphery, grid))))
            self.rec.log(f"remap/{name}/difference", rr.Image(_to_uint8(C.cortical_map(diff, grid))))
        for model, err in (errors or {}).items():
            self.rec.log(f"remap/error/{model}", rr.Scalars(float(err)))

    # ------------------------------------------------------------------ flashes
    def log_flash(self, true_deg: Sequence[float], perceived_deg: Sequence[float],
                  target_deg: Sequence[float] | None = None) -> None:
        """A flash's true and perceived (azimuth_deg, elevation_deg), and optionally the saccade
        target's, in one frame of visual angle (fixation at 0, 0); shown with up = up."""
        pts = [np.asarray(x, float).reshape(2) for x in (true_deg, perceived_deg)]
        if target_deg is not None:
            pts.append(np.asarray(target_deg, float).reshape(2))
        if not all(np.all(np.isfinite(x)) for x in pts):
            raise ValueError("flash positions must be finite (azimuth_deg, elevation_deg)")
        flip = np.array([1.0, -1.0])
        t, p = pts[0], pts[1]
        self.rec.log("flash/fixation", rr.Points2D([[0.0, 0.0]], radii=0.25, colors=[[220, 220, 220]],
                                                   labels=["fixation"]), static=True)
        if target_deg is not None:
            self.rec.log("flash/target", rr.Points2D([pts[2] * flip], radii=0.25, colors=[[255, 160, 0]],
                                                     labels=["saccade target"]))
        self.rec.log("flash/true", rr.Points2D([t * flip], radii=0.25, colors=[[40, 200, 40]]))
        self.rec.log("flash/perceived", rr.Points2D([p * flip], radii=0.25, colors=[[230, 40, 40]]))
        self.rec.log("flash/shift", rr.Arrows2D(vectors=[(p - t) * flip], origins=[t * flip],
                                                colors=[[200, 200, 200]]))

    # ------------------------------------------------------------------ eye kinematics
    def log_eye_angles(self, angles_rad, velocities_rad_s) -> None:
        """(2, 3) Fick angles (rad) and joint rates (rad/s) at the current time, logged in deg, deg/s."""
        ang = np.degrees(np.asarray(angles_rad, float).reshape(2, 3))
        vel = np.degrees(np.asarray(velocities_rad_s, float).reshape(2, 3))
        for e, name in enumerate(EYE_NAMES):
            for j, ax in enumerate(AXIS_NAMES):
                self.rec.log(f"eyes/{name}/angle/{ax}", rr.Scalars(ang[e, j]))
                self.rec.log(f"eyes/{name}/velocity/{ax}", rr.Scalars(vel[e, j]))

    def log_eye_trace(self, trace) -> None:
        """All samples of a ``models.EyeTrace`` at their own times (one column batch per series)."""
        if trace is None or len(trace.times_ms) == 0:
            return
        times = rr.TimeColumn(TIMELINE, duration=np.asarray(trace.times_ms, float) / 1000.0)
        ang = np.degrees(np.asarray(trace.angles, float))
        vel = np.degrees(np.asarray(trace.velocities, float))
        for e, name in enumerate(EYE_NAMES):
            for j, ax in enumerate(AXIS_NAMES):
                for kind, data in (("angle", ang), ("velocity", vel)):
                    self.rec.send_columns(f"eyes/{name}/{kind}/{ax}", indexes=[times],
                                          columns=rr.Scalars.columns(scalars=data[:, e, j]))

    def log_saccade(self, plan) -> None:
        """A saccade's amplitude, peak velocity and duration at its onset (the main sequence)."""
        self.rec.set_time(TIMELINE, duration=float(plan.onset_ms) / 1000.0)
        self.rec.log("saccades/amplitude_deg", rr.Scalars(float(plan.amplitude_deg)))
        self.rec.log("saccades/peak_velocity_deg_s", rr.Scalars(math.degrees(plan.peak_velocity)))
        self.rec.log("saccades/duration_ms", rr.Scalars(float(plan.duration_ms)))
        self.set_time_ms(self.t_ms)


# ---------------------------------------------------------------------- an env run
def _angles_deg(z: complex) -> tuple[float, float]:
    """Image-plane point -> (azimuth_deg, elevation_deg) in that eye's frame."""
    return math.degrees(math.atan(z.real)), math.degrees(math.atan2(z.imag, math.hypot(1.0, z.real)))


def _choose_target(head, rng: np.random.Generator, previous: str | None) -> str | None:
    flashes = set(head.scene.flashes)
    names = [n for n in head.scene.objects if n not in flashes and n != previous]
    if "target" in names and previous != "target" and rng.random() < 0.5:
        return "target"
    return str(rng.choice(names)) if names else None


def record_env_run(path: str | os.PathLike | None, *, steps: int = 4, seed: int = 0, task: str = "fixate",
                   scene: str | None = None, image_size: int = 128, fixation_ms: int = 250,
                   latency_ms: int = 40, flash_lead_ms: int = 20, shift_rings: float = 2.0,
                   remap_model: str = "homography", spawn: bool = False,
                   recording_id: str | None = None) -> dict[str, Any]:
    """Record ``steps`` saccades of ``envs.BinocularSaccadeEnv`` (one env step each, driven through
    ``env.head`` and ``env.vision`` to see inside the saccade).

    Each step: plan a saccade (with ``latency_ms``): even steps to a scene object chosen at random
    (the task's target half the time), odd steps 3-20 deg in a random direction; predict both eyes' post-saccadic samples with every remapping model
    from the pre-saccadic DPFT and the efference copy; step the physics 1 ms at a time through
    the saccade, logging the eye trace (every physics step) and the 3-D head each ms; in the
    ``dots`` scene flash a random flash ``flash_lead_ms`` before onset (images logged at that
    instant) and log its true and perceived position; then ``fixation_ms`` of fixation, render,
    and log images, retina, DPFT, cortex and the remapping (model ``remap_model``) with the
    models' errors. Images are logged only at reset, the flash and the end of each fixation.

    The perceived flash is an illustration of §6.5's remapping by the log-radius shift, not a
    fitted model: the flash's pre-saccadic image point z in the left eye is compressed towards the
    saccade target z_t, z_t + e^{-shift_rings delta} (z - z_t); both are reported as the left
    eye's pre-saccadic (azimuth, elevation). Returns a summary (times, saccades, errors).
    """
    import envs  # heavy (MuJoCo): imported on use
    import models

    if int(steps) != steps or steps < 1:
        raise ValueError(f"steps must be a positive integer; got {steps!r}")
    if remap_model not in envs.REMAP_MODELS:
        raise ValueError(f"remap_model must be one of {envs.REMAP_MODELS}; got {remap_model!r}")
    if int(latency_ms) != latency_ms or not 0 <= flash_lead_ms <= latency_ms:
        raise ValueError("need whole latency_ms >= flash_lead_ms >= 0")
    env = envs.BinocularSaccadeEnv(scene=scene, task=task, image_size=image_size, fixation_ms=fixation_ms,
                                   shift_rings=shift_rings)
    rng = np.random.default_rng(seed)
    summary: dict[str, Any] = {"start_ms": None, "end_ms": None, "saccades": [], "remap_error": []}
    try:
        with Recorder(path, spawn=spawn, recording_id=recording_id) as rec:
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
            rec.set_time_ms(head.time_ms)
            frame, views = look()
            rec.log_head(head)
            log_images(views, frame)
            rec.log_eye_angles(head.eye_angles, np.zeros((2, 3)))
            previous = None
            for step in range(int(steps)):
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
                        plan = head.plan_saccade(amp * math.cos(direction), amp * math.sin(direction),
                                                 latency_ms=latency_ms)
                    except models.OculomotorRangeError:
                        plan = None
                R = plan.efference_copy_eye
                preds = vision.predict_eyes(views, envs.REMAP_MODELS, R)
                flash_ms = plan.onset_ms - int(flash_lead_ms) if head.scene.flashes else None
                z_pre = head.eye_states()[0]
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
                    trace = head.step_ms(1, record=True)
                    rec.log_eye_trace(trace)
                    rec.set_time_ms(head.time_ms)
                    rec.log_head(head)
                trace = head.step_ms(int(fixation_ms), record=True)
                rec.log_eye_trace(trace)
                rec.set_time_ms(head.time_ms)
                rec.log_head(head)
                frame, new_views = look()
                errors = envs.model_errors(preds, new_views)
                log_images(new_views, frame)
                rec.log_remap((preds[0][remap_model], preds[1][remap_model]), new_views, grid, errors)
                views = new_views
                summary["saccades"].append({"onset_ms": plan.onset_ms, "amplitude_deg": plan.amplitude_deg,
                                            "peak_velocity_deg_s": math.degrees(plan.peak_velocity),
                                            "duration_ms": plan.duration_ms})
                summary["remap_error"].append(errors)
            summary["end_ms"] = float(head.time_ms)
    finally:
        env.close()
    return summary


# ---------------------------------------------------------------------- command line
def _run_visualize(args: argparse.Namespace) -> int:
    if args.out is None and not args.spawn:
        args.parser.error("give --out FILE.rrd and/or --spawn")
    try:
        summary = record_env_run(args.out, steps=args.steps, seed=args.seed, task=args.task, scene=args.scene,
                                 image_size=args.image_size, fixation_ms=args.fixation_ms, spawn=args.spawn)
    except (ValueError, FileNotFoundError, KeyError) as e:
        args.parser.error(str(e))
    for i, s in enumerate(summary["saccades"]):
        err = ", ".join(f"{m} {v:.3f}" for m, v in summary["remap_error"][i].items())
        print(f"saccade {i + 1}: {s['amplitude_deg']:.1f} deg, peak {s['peak_velocity_deg_s']:.0f} deg/s, "
              f"{s['duration_ms']:.0f} ms; remap error {err}")
    where = args.out if args.out is not None else "the viewer"
    print(f"recorded {summary['start_ms']:.0f}-{summary['end_ms']:.0f} ms of simulated time to {where}")
    return 0


def add_subcommand(subparsers) -> None:
    """Register ``visualize``: record a run of the environment in Rerun."""
    p = subparsers.add_parser(
        "visualize", help="record a run of the environment in Rerun (--out FILE.rrd or --spawn)",
        description="Run BinocularSaccade-v0 for a few saccades and record the whole pipeline "
                    "(3-D head, eye images with the retina grid, retina samples, DPFT, cortex, remapping, "
                    "flashes, eye angles and velocities at every physics step) on the sim_time timeline.")
    p.add_argument("--out", default=None, help="write the recording to this .rrd file")
    p.add_argument("--spawn", action="store_true", help="open a Rerun viewer and stream to it")
    p.add_argument("--steps", type=int, default=4, help="number of saccades (env steps) to record (default 4)")
    p.add_argument("--seed", type=int, default=0, help="seed of the env and of the saccade choices (default 0)")
    p.add_argument("--task", choices=("fixate", "search", "free"), default="fixate",
                   help="env task (default fixate)")
    p.add_argument("--scene", choices=("bar", "dots", "natural", "search"), default=None,
                   help="scene (default: the task's; fixate uses dots, which has flashes)")
    p.add_argument("--image-size", type=int, default=128, help="eye image size in pixels (default 128)")
    p.add_argument("--fixation-ms", type=int, default=250, help="fixation after each saccade, ms (default 250)")
    p.set_defaults(func=_run_visualize, parser=p)
