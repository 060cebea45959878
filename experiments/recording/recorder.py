"""The project's objects as Rerun archetypes under the entity tree of :mod:`experiments.recording`:
:class:`Recorder`."""

from __future__ import annotations

import datetime
import math
import os
import uuid
from collections.abc import Sequence
from typing import Any

import numpy as np
import rerun as rr

import conformal as C

from .blueprint import blueprint
from .colour import gain_scaled, log_scaled, symmetric_scaled
from .display import _no_display_message, display_available
from .images import grid_strips, hemisphere_image, pinhole_matrix
from .scene_geometry import POSE_TOLERANCE, SceneGeometry

EYE_NAMES = ("left", "right")
AXIS_NAMES = ("h", "v", "t")
TIMELINE = "sim_time"
#: The recordings' timelines: name -> kind. ``sim_time``: simulated time (3-D replay, eye traces of a
#: run); ``flash_time``: ms re saccade onset (a study's flash times and its example eye trace);
#: ``trial``: a study's trial_id; ``env_step``: the env steps (saccades) of a run; ``episode``: its episode.
TIMELINES = {
    "sim_time": "duration",
    "flash_time": "duration",
    "trial": "sequence",
    "env_step": "sequence",
    "episode": "sequence",
}
#: Scalars are logged rounded to this many decimals (deg, deg/s, ms), so that a series that is constant
#: up to float noise (1e-15) is constant and its axis ticks read as plain numbers.
SCALAR_DECIMALS = 6
#: The scene objects labelled in the 3-D view (the others -- markers, ruler, search items -- are drawn
#: unlabelled: at the default camera their labels overlapped).
LABELLED_OBJECTS = ("fixation", "target")
#: How often a recording written to a file only is flushed into chunks (see ``Recorder``).
FILE_FLUSH_TICK = datetime.timedelta(seconds=30)
#: How far above (or below) its object a 3-D label is drawn (m).
LABEL_OFFSET_M = 0.06
#: Rows of black between the two hemispheres in ``cortex/map``.
CORTEX_GAP = 2
#: The application id of ``study.rrd``; a Recorder with it gets the ``"study"`` layout.
STUDY_APP_ID = "conformal_head_study"
_AXIS_COLORS = np.array([[220, 50, 50], [50, 180, 50], [60, 90, 230]], np.uint8)
_DOT = rr.components.Radius.ui_points(5.0)  # 2-D dots: a size on screen, whatever the zoom
_EYE_COLORS = {"left": [60, 120, 255], "right": [255, 120, 60]}


def _round(v):
    """Scalars as logged: rounded to ``SCALAR_DECIMALS`` (float noise such as -1e-15 becomes 0.0)."""
    return np.round(np.asarray(v, float), SCALAR_DECIMALS) + 0.0


class Recorder:
    """Log the pipeline to a Rerun recording (see :mod:`experiments.recording` for the entity tree).

    ``path`` saves an ``.rrd`` file; ``spawn=True`` opens a native viewer (needs a display);
    ``connect`` streams to a running viewer or proxy (a ``rerun+http://.../proxy`` URL such as
    ``WebViewer.grpc_url``). ``path`` may be combined with either. With none, data is buffered in
    memory and dropped. Call :meth:`set_time_ms` before logging what belongs to an instant, and
    :meth:`close` at the end (or use it as a context manager). ``layout`` picks the blueprint
    (``"run"``, or ``"study"``; default ``"study"`` for ``app_id == STUDY_APP_ID``);
    ``image_plane_distance`` is how far out (m) the 3-D view draws each eye's image in its frustum;
    ``log_time=False`` leaves out Rerun's wall-clock ``log_time`` timeline.
    """

    def __init__(
        self,
        path: str | os.PathLike | None = None,
        *,
        spawn: bool = False,
        connect: str | None = None,
        app_id: str = "conformal_head",
        recording_id: str | None = None,
        gaze_length: float = 1.0,
        image_plane_distance: float = 0.3,
        layout: str | None = None,
        log_time: bool = True,
    ) -> None:
        if not app_id:
            raise ValueError("app_id must be a non-empty string")
        for name, v in (("gaze_length", gaze_length), ("image_plane_distance", image_plane_distance)):
            if (
                isinstance(v, bool)
                or not isinstance(v, (int, float, np.integer, np.floating))
                or not (math.isfinite(v) and v > 0)
            ):
                raise ValueError(f"{name} must be a positive number of metres; got {v!r}")
        if spawn and connect is not None:
            raise ValueError("give spawn=True or connect=URL, not both")
        if spawn and not display_available():
            raise RuntimeError(_no_display_message("spawn=True"))
        if connect is not None and not str(connect).startswith(("rerun://", "rerun+http://", "rerun+https://")):
            raise ValueError(f"connect must be a rerun://, rerun+http:// or rerun+https:// URL; got {connect!r}")
        self.path = None if path is None else os.fspath(path)
        if self.path is not None:
            if not self.path.strip():
                raise ValueError("path must name a file, e.g. 'run.rrd'; got ''")
            if os.path.isdir(self.path):
                raise ValueError(
                    f"path {self.path!r} is a directory; give a file such as {os.path.join(self.path, 'run.rrd')!r}"
                )
        layout = layout or ("study" if app_id == STUDY_APP_ID else "run")
        bp = blueprint(layout)
        self.gaze_length = float(gaze_length)
        self.image_plane_distance = float(image_plane_distance)
        rid = recording_id or str(uuid.uuid4())
        streaming = spawn or connect is not None
        # A file is read all at once: large chunks (a flush per 16 MiB or 30 s instead of Rerun's 2 MiB or
        # 200 ms) make a recording of thousands of small logs open in seconds, not minutes. A viewer that
        # is watching gets Rerun's default, low-latency batching.
        batcher = (
            None
            if streaming
            else rr.ChunkBatcherConfig(flush_tick=FILE_FLUSH_TICK, flush_num_bytes=16 * 2**20, flush_num_rows=2**20)
        )
        self.rec = rr.RecordingStream(app_id, recording_id=rid, batcher_config=batcher)
        if not log_time:  # no wall-clock timeline: the same data makes the same recording
            self.rec.set_log_time_enabled(False)
        self.rec.reset_time()  # Rerun keeps a thread's times per recording id: start from none
        self._streaming = streaming
        if self.path is not None:
            os.makedirs(os.path.dirname(os.path.abspath(self.path)), exist_ok=True)
        if self._streaming:
            if spawn:
                rr.spawn(connect=False, recording=self.rec)
            sinks: list = [rr.GrpcSink(connect) if connect is not None else rr.GrpcSink()]
            if self.path is not None:
                sinks.append(rr.FileSink(self.path))
            self.rec.set_sinks(*sinks, default_blueprint=bp)
        elif self.path is not None:
            self.rec.save(self.path, default_blueprint=bp)
        self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self.t_ms = 0.0
        self._logged_once: set[str] = set()
        self._scenes: dict[int, tuple[Any, SceneGeometry]] = {}
        self._last: dict[str, np.ndarray] = {}
        self._closed = False

    # ------------------------------------------------------------------ plumbing
    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def set_time_ms(self, t_ms: float) -> None:
        """Set the ``sim_time`` timeline to ``t_ms`` simulated milliseconds. Going back in time
        makes the next 3-D logs log everything again (what is unchanged is only skipped forwards)."""
        t = float(t_ms)
        if not math.isfinite(t):
            raise ValueError(f"t_ms must be finite; got {t_ms!r}")
        if t < self.t_ms:
            self._forget()
        self.t_ms = t
        self.rec.set_time(TIMELINE, duration=t / 1000.0)

    def set_time(self, timeline: str, value: float | int) -> None:
        """Set one of :data:`TIMELINES` (``sim_time`` and ``flash_time`` in ms, the others whole
        numbers) for what is logged next; :meth:`set_time_ms` is ``set_time("sim_time", t)``."""
        if timeline == TIMELINE:
            self.set_time_ms(value)
            return
        kind = TIMELINES.get(timeline)
        if kind is None:
            raise ValueError(f"timeline must be one of {tuple(TIMELINES)}; got {timeline!r}")
        v = float(value)
        if not math.isfinite(v) or (kind == "sequence" and (v != int(v) or v < 0)):
            raise ValueError(
                f"{timeline} must be {'a whole number >= 0' if kind == 'sequence' else 'finite'}; got {value!r}"
            )
        if kind == "sequence":
            self.rec.set_time(timeline, sequence=int(v))
        else:
            self.rec.set_time(timeline, duration=v / 1000.0)

    def reset_time(self) -> None:
        """What is logged next is on no timeline until one is set (``sim_time`` restarts from 0)."""
        self.rec.reset_time()
        self._forget()
        self.t_ms = 0.0

    def send_columns(self, entity: str, indexes: list, columns) -> None:
        """Many rows at once (``rr.TimeColumn`` indexes, an archetype's ``.columns(...)``): one chunk,
        not one per row (escape hatch, as :meth:`log`)."""
        self.rec.send_columns(entity, indexes=indexes, columns=columns)

    def send_scalars(self, entity: str, indexes: list, values) -> None:
        """A whole series at once (``rr.TimeColumn`` indexes), rounded as every scalar here."""
        self.send_columns(entity, indexes, rr.Scalars.columns(scalars=_round(values)))

    def clear_time(self, timeline: str) -> None:
        """What is logged next is not on ``timeline`` (until it is set again)."""
        if timeline not in TIMELINES:
            raise ValueError(f"timeline must be one of {tuple(TIMELINES)}; got {timeline!r}")
        self.rec.disable_timeline(timeline)

    def log_picture(self, entity: str, pixels: np.ndarray, value_range: tuple[float, float], scale: str) -> None:
        """A scaled picture (uint8 RGB, from :mod:`.colour`) and, beside it, the values its colour map
        spans and how (``value_range``, ``scale``: shown in the viewer's selection panel)."""
        self.rec.log(entity, rr.Image(pixels), rr.AnyValues(value_range=np.asarray(value_range, float), scale=scale))

    def _forget(self) -> None:
        self._last.clear()
        for _, scene in self._scenes.values():
            scene.reset()

    def _changed(self, entity: str, key, tol: float = 0.0) -> bool:
        key = np.asarray(key, float).ravel()
        old = self._last.get(entity)
        if old is not None and old.shape == key.shape and np.all(np.abs(old - key) <= tol):
            return False
        self._last[entity] = key
        return True

    def log(self, entity: str, archetype: Any, *, static: bool = False) -> None:
        """Log any Rerun archetype at the current time (escape hatch for other modules)."""
        self.rec.log(entity, archetype, static=static)

    def close(self) -> None:
        """Flush and close the recording (the ``.rrd`` file is complete afterwards)."""
        if self._closed:
            return
        self._closed = True
        if self._streaming:
            self.rec.flush(timeout_sec=60.0)  # a viewer that went away must not hang us
        else:
            self.rec.flush()
        self.rec.disconnect()

    # ------------------------------------------------------------------ 3-D
    def log_scene(self, model, data) -> int:
        """The MuJoCo scene's geoms and body poses (``world/scene/...``, see :class:`SceneGeometry`),
        as far as they are new or changed; returns how many entities were logged."""
        entry = self._scenes.get(id(model))
        if entry is None or entry[0] is not model:
            entry = (model, SceneGeometry(model))
            self._scenes[id(model)] = entry
        return entry[1].log(self.rec, data)

    def log_eye_camera(self, eye: str, position, xmat, image_shape: tuple[int, int], pixels_per_unit: float) -> None:
        """``world/eyes/{eye}/camera``: the camera's world pose; ``.../camera/image``: its Pinhole
        (logged when they change)."""
        if eye not in EYE_NAMES:
            raise ValueError(f"eye must be one of {EYE_NAMES}; got {eye!r}")
        p = np.asarray(position, float).reshape(3)
        R = np.asarray(xmat, float).reshape(3, 3)
        h, w = (int(v) for v in image_shape[:2])
        f = float(pixels_per_unit)
        if not (np.all(np.isfinite(p)) and np.all(np.isfinite(R)) and math.isfinite(f) and f > 0 and h > 0 and w > 0):
            raise ValueError("eye camera pose, image shape and focal length must be finite and positive")
        path = f"world/eyes/{eye}/camera"
        if self._changed(path, np.concatenate([p, R.ravel()]), POSE_TOLERANCE):
            self.rec.log(path, rr.Transform3D(translation=p, mat3x3=R))
        if self._changed(path + "/image#pinhole", [h, w, f, self.image_plane_distance]):
            self.rec.log(
                path + "/image",
                rr.Pinhole(
                    image_from_camera=pinhole_matrix(h, w, f),
                    resolution=[w, h],
                    camera_xyz=rr.ViewCoordinates.RUB,
                    color=_EYE_COLORS[eye],
                    image_plane_distance=self.image_plane_distance,
                ),
            )

    def log_head(self, head) -> None:
        """The scene's geoms and moving bodies, both eye cameras (pose and pinhole), head pose and
        axes, eye positions, gaze rays, scene objects and visible flashes."""
        self.log_scene(head.model, head.data)
        origin = head.to_world(np.zeros(3))
        axes = np.stack([head.to_world(np.eye(3)[i]) - origin for i in range(3)])
        self.rec.log("world/head/origin", rr.Points3D([origin], radii=0.01, colors=[[200, 200, 200]]))
        self.rec.log(
            "world/head/axes", rr.Arrows3D(vectors=0.1 * axes, origins=np.repeat([origin], 3, 0), colors=_AXIS_COLORS)
        )
        for name, state in zip(EYE_NAMES, head.eye_states()):
            p = np.asarray(state.camera_position, float)
            self.log_eye_camera(name, p, state.camera_xmat, head.image_shape, head.pixels_per_unit)
            gaze = np.asarray(state.eye_axes, float)[:, 1] * self.gaze_length
            color = [_EYE_COLORS[name]]
            self.rec.log(f"world/eyes/{name}/position", rr.Points3D([p], radii=0.012, colors=color))
            self.rec.log(f"world/eyes/{name}/gaze", rr.Arrows3D(vectors=[gaze], origins=[p], colors=color))
        flashes = set(head.scene.flashes)
        names = [n for n in head.scene.objects if n not in flashes]
        if names:
            pos = np.stack([head.object_position(n) for n in names])
            colors = [[255, 60, 60] if n == "target" else [230, 230, 230] for n in names]
            self.rec.log("world/objects", rr.Points3D(pos, radii=rr.components.Radius.ui_points(4.0), colors=colors))
            self._log_labels(
                [n for n in names if n in LABELLED_OBJECTS], [p for n, p in zip(names, pos) if n in LABELLED_OBJECTS]
            )
        visible = list(head.visible_flashes)
        pos = np.stack([head.object_position(n) for n in visible]) if visible else np.zeros((0, 3))
        self.rec.log("world/flashes", rr.Points3D(pos, radii=0.015, colors=[[255, 255, 0]] * len(visible)))

    def _log_labels(self, names: list[str], positions: list[np.ndarray]) -> None:
        """``world/labels``: the labelled objects' names, each :data:`LABEL_OFFSET_M` above or below its
        object (the higher object's above, the lower one's below), so that two labels never sit on the
        same line of the default view, however close the objects are."""
        if not names:
            return
        sign = -np.ones(len(names))
        sign[int(np.argmax([p[2] for p in positions]))] = 1.0  # the highest (the first of equals) above
        pos = np.array(positions, float) + np.outer(sign, [0.0, 0.0, LABEL_OFFSET_M])
        self.rec.log(
            "world/labels",
            rr.Points3D(
                pos, radii=rr.components.Radius.ui_points(0.5), labels=names, colors=[[255, 255, 255]], show_labels=True
            ),
        )

    # ------------------------------------------------------------------ images
    def log_frame(self, frame, grid: C.RetinaGrid, target_px=None) -> None:
        """Both eyes' images, gain-scaled (2-D, and in each eye's frustum in 3-D with the camera pose at
        render time); the retina grid overlay (logged once per eye, static); the target.

        ``target_px``: (2, 2) [eye, (row, col)] as from ``Head.project_to_pixels`` (pixel centres
        at integers), or (2, 1, 2) of that, or None.
        """
        tp = None if target_px is None else np.asarray(target_px, float).reshape(2, -1, 2)
        for i, (name, eye) in enumerate(zip(EYE_NAMES, (frame.left, frame.right))):
            img = np.asarray(eye.image)
            pix, rng = gain_scaled(img)  # a dark screen's few bright dots: full scale, hue kept
            self.log_picture(f"eyes/{name}/image", pix, rng, "gain")
            self.log_eye_camera(name, eye.camera_position, eye.camera_xmat, img.shape[:2], eye.pixels_per_unit)
            self.log_picture(f"world/eyes/{name}/camera/image", pix, rng, "gain")
            if name not in self._logged_once:
                strips = grid_strips(grid, img.shape[:2], eye.pixels_per_unit)
                self.rec.log(
                    f"eyes/{name}/grid", rr.LineStrips2D(strips, colors=[[0, 200, 200, 110]], radii=0.25), static=True
                )
                self._logged_once.add(name)
            if tp is not None:
                xy = np.stack([tp[i, :, 1] + 0.5, tp[i, :, 0] + 0.5], -1)
                self.rec.log(f"eyes/{name}/target", rr.Points2D(xy, radii=2.5, colors=[[255, 40, 40]]))

    def log_views(self, views, grid: C.RetinaGrid, *, dpft=None, cortex=None) -> None:
        """Each eye's foveal and log-polar samples (gain-scaled), the DPFT's log-magnitude (top three
        decades, zero frequency centred) and both hemispheres of the cortex (each gain-scaled), see
        :data:`.colour.PANEL_SCALES`. ``dpft`` and ``cortex`` (default ``views``) are other views whose
        DPFT and cortex to show instead (a study shows those of the flash response)."""
        for name, v in zip(EYE_NAMES, views):
            self.log_picture(f"retina/{name}/fovea", *gain_scaled(C.fovea_image(v.fovea, grid)), "gain")
            self.log_picture(f"retina/{name}/logpolar", *gain_scaled(v.periphery), "gain")
        for name, v in zip(EYE_NAMES, dpft or views):
            pix, rng = log_scaled(np.fft.fftshift(np.abs(np.asarray(v.coeffs)), axes=(0, 1)))
            self.log_picture(f"dpft/{name}/log_magnitude", pix, rng, "log10")
        src = cortex or views
        bc = C.binocular_cortex(src[0].periphery, src[1].periphery, grid)
        rh, lh = hemisphere_image(bc.right_hemisphere), hemisphere_image(bc.left_hemisphere)
        if cortex is not None and rh.ndim == 3:  # a flash response: its strength, one channel
            rh, lh = rh.mean(axis=-1), lh.mean(axis=-1)
        gap = np.zeros((CORTEX_GAP,) + rh.shape[1:])
        pix, rng = gain_scaled(np.concatenate([rh, gap, lh]), "magma" if cortex is not None else "gray")
        self.log_picture("cortex/map", pix, rng, "gain")
        if "cortex" not in self._logged_once:
            self._log_cortex_labels(grid)
            self._logged_once.add("cortex")

    def log_flash_response(self, views, grid: C.RetinaGrid) -> None:
        """Each eye's log-polar response to a flash (flash minus no flash, >= 0), gain-scaled, magma."""
        for name, v in zip(EYE_NAMES, views):
            p = np.asarray(v.periphery, float)
            self.log_picture(
                f"retina/{name}/flash_response", *gain_scaled(p.mean(axis=-1) if p.ndim == 3 else p), "gain"
            )

    def _log_cortex_labels(self, grid: C.RetinaGrid) -> None:
        """Labels in words on ``cortex/map`` (static), above and below the picture so as not to cover
        it: which hemisphere (and visual field) each half is; the columns are left eye | right eye."""
        rows, cols = grid.N // 2, 2 * grid.M
        pos = [[cols / 2, -1.5], [cols / 2, 2 * rows + CORTEX_GAP + 1.5]]
        labels = [
            "right hemisphere (left visual field): left eye | right eye",
            "left hemisphere (right visual field): left eye | right eye",
        ]
        self.rec.log(
            "cortex/labels",
            rr.Points2D(
                pos,
                radii=rr.components.Radius.ui_points(0.5),
                labels=labels,
                colors=[[120, 220, 255]],
                show_labels=True,
            ),
            static=True,
        )

    def log_remap(self, predicted, actual, grid: C.RetinaGrid, errors: dict[str, float] | None = None) -> None:
        """Predicted (from the pre-saccadic DPFT and the efference copy) vs actual post-saccadic
        cortical maps of each eye and their absolute difference; optional per-model errors."""
        for name, p, a in zip(EYE_NAMES, predicted, actual):
            pm = np.asarray(p.mask, bool)[..., None]
            both = pm & np.asarray(a.mask, bool)[..., None]
            pred = np.where(pm, np.clip(p.periphery, 0.0, 1.0), 0.0)  # as the env's ``remapped``
            act = np.clip(a.periphery, 0.0, 1.0)
            diff = np.where(both, pred - act, 0.0)
            peak = max(float(pred.max()), float(act.max()))
            self.log_picture(f"remap/{name}/predicted", *gain_scaled(C.cortical_map(pred, grid), peak=peak), "gain")
            self.log_picture(f"remap/{name}/actual", *gain_scaled(C.cortical_map(act, grid), peak=peak), "gain")
            self.log_picture(f"remap/{name}/difference", *symmetric_scaled(C.cortical_map(diff, grid)), "symmetric")
        for model, err in (errors or {}).items():
            self.rec.log(f"remap/error/{model}", rr.Scalars(_round(err)))

    # ------------------------------------------------------------------ flashes
    def log_flash(
        self,
        true_deg: Sequence[float],
        perceived_deg: Sequence[float],
        target_deg: Sequence[float] | None = None,
        fixation_deg: Sequence[float] = (0.0, 0.0),
    ) -> None:
        """A flash's true and perceived (azimuth_deg, elevation_deg), and optionally the saccade
        target's, in one frame of visual angle with the fixation point at ``fixation_deg`` (static:
        one per recording); shown with up = up."""
        pts = [np.asarray(x, float).reshape(2) for x in (true_deg, perceived_deg, fixation_deg)]
        if target_deg is not None:
            pts.append(np.asarray(target_deg, float).reshape(2))
        if not all(np.all(np.isfinite(x)) for x in pts):
            raise ValueError("flash positions must be finite (azimuth_deg, elevation_deg)")
        flip = np.array([1.0, -1.0])
        t, p = pts[0], pts[1]
        if "flash/fixation" not in self._logged_once:
            self.rec.log(
                "flash/fixation", rr.Points2D([pts[2] * flip], radii=_DOT, colors=[[220, 220, 220]]), static=True
            )  # unlabelled (labels hid the flash): the panel's title names the colours
            self._logged_once.add("flash/fixation")
        if target_deg is not None:
            self.rec.log("flash/target", rr.Points2D([pts[3] * flip], radii=_DOT, colors=[[255, 160, 0]]))
        self.rec.log("flash/true", rr.Points2D([t * flip], radii=_DOT, colors=[[40, 200, 40]]))
        self.rec.log("flash/perceived", rr.Points2D([p * flip], radii=_DOT, colors=[[230, 40, 40]]))
        self.rec.log("flash/shift", rr.Arrows2D(vectors=[(p - t) * flip], origins=[t * flip], colors=[[200, 200, 200]]))

    # ------------------------------------------------------------------ eye kinematics
    def log_eye_angles(self, angles_rad, velocities_rad_s, signal_rad=None) -> None:
        """(2, 3) Fick angles (rad), joint rates (rad/s) and, if given, the eye-position signal
        (rad) at the current time, logged in deg, deg/s."""
        ang = np.degrees(np.asarray(angles_rad, float).reshape(2, 3))
        vel = np.degrees(np.asarray(velocities_rad_s, float).reshape(2, 3))
        sig = None if signal_rad is None else np.degrees(np.asarray(signal_rad, float).reshape(2, 3))
        for e, name in enumerate(EYE_NAMES):
            for j, ax in enumerate(AXIS_NAMES):
                self.rec.log(f"eyes/{name}/angle/{ax}", rr.Scalars(_round(ang[e, j])))
                self.rec.log(f"eyes/{name}/velocity/{ax}", rr.Scalars(_round(vel[e, j])))
                if sig is not None:
                    self.rec.log(f"eyes/{name}/signal/{ax}", rr.Scalars(_round(sig[e, j])))

    def log_eye_trace(self, trace) -> None:
        """All samples of a ``models.EyeTrace`` at their own times (one column batch per series)."""
        if trace is None or len(trace.times_ms) == 0:
            return
        times = rr.TimeColumn(TIMELINE, duration=np.asarray(trace.times_ms, float) / 1000.0)
        series = [
            ("angle", np.degrees(np.asarray(trace.angles, float))),
            ("velocity", np.degrees(np.asarray(trace.velocities, float))),
        ]
        if trace.eye_position_signal is not None:
            series.append(("signal", np.degrees(np.asarray(trace.eye_position_signal, float))))
        for e, name in enumerate(EYE_NAMES):
            for j, ax in enumerate(AXIS_NAMES):
                for kind, data in series:
                    self.send_scalars(f"eyes/{name}/{kind}/{ax}", [times], data[:, e, j])

    def log_saccade(self, plan) -> None:
        """A saccade's amplitude, peak velocity and duration at its onset (the main sequence)."""
        self.rec.set_time(TIMELINE, duration=float(plan.onset_ms) / 1000.0)
        self.rec.log("saccades/amplitude_deg", rr.Scalars(_round(plan.amplitude_deg)))
        self.rec.log("saccades/peak_velocity_deg_s", rr.Scalars(_round(math.degrees(plan.peak_velocity))))
        self.rec.log("saccades/duration_ms", rr.Scalars(_round(plan.duration_ms)))
        self.rec.log("saccades/endpoint_error_deg", rr.Scalars(_round(plan.endpoint_error_deg.mean())))
        self.set_time_ms(self.t_ms)
