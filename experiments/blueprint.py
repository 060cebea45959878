"""The Rerun blueprints (view layouts) sent with the recordings of :mod:`experiments.recording`.

``blueprint("run")`` (``visualize``), rows top to bottom: the head in its scene in 3-D (the
scene's geoms, both eyes' cameras as frusta with their images in them, gaze rays) and both eyes'
images with the retina grid; the retinas (foveal and log-polar samples) and the DPFT
log-magnitudes; the cortex (both hemispheres) and the remapping (predicted, actual, |difference|)
of each eye; time series of eye angles and velocities, remapping errors, the flash positions and
each saccade's amplitude, peak velocity and duration (the main sequence).

``blueprint("study")`` (``study.rrd``): the same two first rows without the saccade target and the
remapping; then every
trial's true and perceived flash positions at the current flash time, the example trial's flash,
the compression index and the remapping gain over time, and the example trial's eye angles and
velocities.

View contents are entity paths or ``path/**`` subtrees only: Rerun 0.41 supports no other ``*``.
"""

from __future__ import annotations

import rerun.blueprint as rrb

__all__ = ["blueprint", "LAYOUTS", "SCENE_EYE_POSITION", "SCENE_LOOK_TARGET"]

EYE_NAMES = ("left", "right")
LAYOUTS = ("run", "study")
#: Where the 3-D view looks from and at (world metres, z up): behind the head, above and to its
#: left, looking past it at the screen 1 m ahead of the eyes.
SCENE_EYE_POSITION = (-0.7, 0.75, 1.75)
SCENE_LOOK_TARGET = (0.5, -0.05, 1.15)


def _image_view(origin: str, name: str) -> rrb.Spatial2DView:
    return rrb.Spatial2DView(origin=origin, contents="$origin/**", name=name)


def _scene_view() -> rrb.Spatial3DView:
    return rrb.Spatial3DView(
        origin="world", contents="$origin/**", name="head in its scene: eye frusta with their images",
        eye_controls=rrb.EyeControls3D(position=SCENE_EYE_POSITION, look_target=SCENE_LOOK_TARGET,
                                       eye_up=(0.0, 0.0, 1.0)),
        line_grid=rrb.LineGrid3D(visible=False), background=[150, 158, 170],
    )


def _top(target: bool) -> rrb.Horizontal:
    eyes = [
        rrb.Spatial2DView(origin=f"eyes/{e}", name=f"{e} eye image + retina grid",
                          contents=[f"eyes/{e}/image", f"eyes/{e}/grid"] + ([f"eyes/{e}/target"] if target else []))
        for e in EYE_NAMES
    ]
    return rrb.Horizontal(_scene_view(), *eyes, column_shares=[2, 1, 1])


def _retina() -> rrb.Grid:
    return rrb.Grid(
        *[_image_view(f"retina/{e}/fovea", f"{e} fovea") for e in EYE_NAMES],
        *[_image_view(f"retina/{e}/logpolar", f"{e} log-polar [ring, sector]") for e in EYE_NAMES],
        *[_image_view(f"dpft/{e}/log_magnitude", f"{e} DPFT log|F|") for e in EYE_NAMES],
        grid_columns=2,
    )


def _cortex() -> rrb.Vertical:
    return rrb.Vertical(
        _image_view("cortex/right_hemisphere", "right hemisphere (left hemifield; L eye | R eye)"),
        _image_view("cortex/left_hemisphere", "left hemisphere (right hemifield; L eye | R eye)"),
    )


def _eye_plots() -> list[rrb.TimeSeriesView]:
    return [
        rrb.TimeSeriesView(origin="eyes", contents=[f"eyes/{e}/{k}/**" for e in EYE_NAMES for k in ("angle", "signal")],
                           name="eye angles and the eye-position signal (deg)"),
        rrb.TimeSeriesView(origin="eyes", contents=[f"eyes/{e}/velocity/**" for e in EYE_NAMES],
                           name="eye velocity (deg/s)"),
    ]


def _flash_view() -> rrb.Spatial2DView:
    """The flash in degrees of visual angle (x azimuth, y = -elevation), fixed to +-30 x +-18 deg
    so that every flash of a run is shown in the same frame."""
    return rrb.Spatial2DView(origin="flash", name="flash: true (green) vs perceived (red), deg",
                             visual_bounds=rrb.VisualBounds2D(x_range=(-30.0, 30.0), y_range=(-18.0, 18.0)))


def blueprint(layout: str = "run") -> rrb.Blueprint:
    """The layout of a recording (``"run"`` or ``"study"``, see the module docstring); the time
    panel shows the ``sim_time`` timeline, following the latest data (so a finished recording
    opens at its end)."""
    if layout not in LAYOUTS:
        raise ValueError(f"layout must be one of {LAYOUTS}; got {layout!r}")
    if layout == "run":
        remap = rrb.Grid(
            *[_image_view(f"remap/{e}/{kind}", f"{e} {kind}")
              for e in EYE_NAMES for kind in ("predicted", "actual", "difference")],
            grid_columns=3,
        )
        middle = rrb.Horizontal(_retina(), _cortex(), remap, column_shares=[1, 1, 1.6])
        plots = rrb.Horizontal(
            *_eye_plots(),
            rrb.TimeSeriesView(origin="remap/error", name="remap error (normalized RMS)"),
            _flash_view(),
            rrb.TimeSeriesView(origin="saccades",
                               name="saccades: amplitude (deg), peak velocity (deg/s), duration (ms), endpoint error (deg)"),
        )
    else:
        middle = rrb.Horizontal(_retina(), _cortex(), column_shares=[1, 1])
        plots = rrb.Horizontal(
            rrb.Spatial2DView(origin="study", contents=["study/true", "study/perceived", "study/error"],
                              name="all trials at this flash time: true (green) vs perceived (red), deg"),
            _flash_view(),
            rrb.TimeSeriesView(origin="study/compression_index", name="compression index"),
            rrb.TimeSeriesView(origin="study/gain", name="remapping gain"),
            *_eye_plots(),
        )
    layout_ = rrb.Vertical(_top(layout == "run"), middle, plots, row_shares=[1.6, 1.2, 1])
    time_panel = rrb.TimePanel(timeline="sim_time", play_state="following", state="collapsed")
    return rrb.Blueprint(layout_, time_panel, collapse_panels=True)
