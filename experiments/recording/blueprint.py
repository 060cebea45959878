"""The Rerun blueprints (view layouts) sent with the recordings of :mod:`experiments.recording`.
Every panel is titled in words: what the eye sees, what the retina samples, the DPFT, the cortex,
the percept.

``blueprint("run")`` (``visualize``), rows top to bottom: the head in its scene in 3-D (the
scene's geoms, both eyes' cameras as frusta with their images in them, gaze rays, the fixation point
and target labelled) and what each eye sees with the retina grid; the retinas (foveal and log-polar
samples) and the DPFT log-magnitudes; the cortex (both hemispheres, labelled) and the remapping
(predicted, actual, predicted - actual) of each eye; time series of eye angles and velocities,
remapping errors, the flash's percept and each saccade's amplitude, peak velocity and duration (the
main sequence). The time panel shows ``sim_time``.

``blueprint("study")`` (``study.rrd``): the same first row at the flash (no saccade target); the
retinas, the flash's response and its DPFT; the cortex's response to the flash; then the percept of
every trial at the current flash time (or of one trial, on the ``trial`` timeline), the example
trial's flash, the compression index and the mean remapping gain against flash time, and the example
trial's eyes and eye-position signal. The time panel shows ``flash_time`` (ms re saccade onset).

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


def _scene_view(study: bool) -> rrb.Spatial3DView:
    name = (
        "the head at the flash (3-D): each eye's frustum holds what it sees"
        if study
        else "the head in its scene (3-D): each eye's frustum holds what it sees"
    )
    return rrb.Spatial3DView(
        origin="world",
        contents="$origin/**",
        name=name,
        eye_controls=rrb.EyeControls3D(
            position=SCENE_EYE_POSITION, look_target=SCENE_LOOK_TARGET, eye_up=(0.0, 0.0, 1.0)
        ),
        line_grid=rrb.LineGrid3D(visible=False),
        background=[150, 158, 170],
    )


def _top(study: bool) -> rrb.Horizontal:
    what = "at the flash" if study else "now"
    eyes = [
        rrb.Spatial2DView(
            origin=f"eyes/{e}",
            name=f"what the {e} eye sees {what}, with the retina grid",
            contents=[f"eyes/{e}/image", f"eyes/{e}/grid"] + ([] if study else [f"eyes/{e}/target"]),
        )
        for e in EYE_NAMES
    ]
    return rrb.Horizontal(_scene_view(study), *eyes, column_shares=[2, 1, 1])


def _retina(study: bool) -> rrb.Grid:
    views = [
        *[_image_view(f"retina/{e}/fovea", f"what the {e} retina samples: fovea") for e in EYE_NAMES],
        *[_image_view(f"retina/{e}/logpolar", f"{e} retina: log-polar periphery [ring x sector]") for e in EYE_NAMES],
    ]
    if study:
        views += [
            _image_view(f"retina/{e}/flash_response", f"{e} retina: the flash's response (flash - no flash)")
            for e in EYE_NAMES
        ]
    of = "the flash's response" if study else "the periphery"
    views += [
        _image_view(f"dpft/{e}/log_magnitude", f"the DPFT of {of}, {e} eye: log10|F| (3 decades)") for e in EYE_NAMES
    ]
    return rrb.Grid(*views, grid_columns=2)


def _cortex(study: bool) -> rrb.Spatial2DView:
    of = "the flash's response" if study else "both eyes' samples"
    return rrb.Spatial2DView(
        origin="cortex", contents="$origin/**", name=f"the cortex: {of} in both hemispheres (log-polar map)"
    )


def _eye_plots(study: bool) -> list[rrb.TimeSeriesView]:
    if study:
        return [
            rrb.TimeSeriesView(
                origin="eyes",
                contents=[f"eyes/{e}/{k}/**" for e in EYE_NAMES for k in ("angle", "signal")],
                name="the example trial's eyes and eye-position signal (deg) re saccade onset",
            )
        ]
    return [
        rrb.TimeSeriesView(
            origin="eyes",
            contents=[f"eyes/{e}/{k}/**" for e in EYE_NAMES for k in ("angle", "signal")],
            name="eye angles and the eye-position signal (deg)",
        ),
        rrb.TimeSeriesView(
            origin="eyes",
            contents=[f"eyes/{e}/velocity/**" for e in EYE_NAMES],
            name="how fast the eyes turn: eye velocity (deg/s)",
        ),
    ]


def _flash_view(study: bool) -> rrb.Spatial2DView:
    """The flash in degrees of visual angle (x azimuth, y = -elevation), fixed to +-30 x +-18 deg
    so that every flash of a run is shown in the same frame."""
    name = (
        "the percept of the example trial: flash true (green), perceived (red); fixation (gray), target (orange); deg"
        if study
        else "the percept: flash true (green) vs perceived (red); fixation (gray), target (orange); deg"
    )
    return rrb.Spatial2DView(
        origin="flash", name=name, visual_bounds=rrb.VisualBounds2D(x_range=(-30.0, 30.0), y_range=(-18.0, 18.0))
    )


def blueprint(layout: str = "run") -> rrb.Blueprint:
    """The layout of a recording (``"run"`` or ``"study"``, see the module docstring); the time
    panel shows ``sim_time`` (run) or ``flash_time`` (study), following the latest data (so a finished
    recording opens at its end)."""
    if layout not in LAYOUTS:
        raise ValueError(f"layout must be one of {LAYOUTS}; got {layout!r}")
    study = layout == "study"
    if not study:
        remap = rrb.Grid(
            *[
                _image_view(f"remap/{e}/{kind}", f"remapping, {e} eye: {what}")
                for e in EYE_NAMES
                for kind, what in (
                    ("predicted", "predicted from the efference copy"),
                    ("actual", "actual after the saccade"),
                    ("difference", "predicted - actual"),
                )
            ],
            grid_columns=3,
        )
        middle = rrb.Horizontal(_retina(False), _cortex(False), remap, column_shares=[1, 1, 1.6])
        plots = rrb.Horizontal(
            *_eye_plots(False),
            rrb.TimeSeriesView(origin="remap/error", name="remapping error of each model (normalized RMS)"),
            _flash_view(False),
            rrb.TimeSeriesView(
                origin="saccades",
                name="saccades: amplitude (deg), peak velocity (deg/s), duration (ms), endpoint error (deg)",
            ),
        )
    else:
        middle = rrb.Horizontal(_retina(True), _cortex(True), column_shares=[1, 1])
        plots = rrb.Horizontal(
            rrb.Spatial2DView(
                origin="study",
                contents=["study/true", "study/perceived", "study/error"],
                name="the percept: true (green) vs perceived (red), deg, of every trial at this "
                "flash time (or of one trial, on the 'trial' timeline)",
                visual_bounds=rrb.VisualBounds2D(x_range=(-30.0, 30.0), y_range=(-18.0, 18.0)),
            ),
            _flash_view(True),
            rrb.TimeSeriesView(
                origin="study/compression_index",
                name="compression index vs flash time re saccade onset, per saccade amplitude",
            ),
            rrb.TimeSeriesView(origin="study/gain", name="mean remapping gain vs flash time, per saccade amplitude"),
            *_eye_plots(True),
        )
    layout_ = rrb.Vertical(_top(study), middle, plots, row_shares=[1.6, 1.2, 1])
    time_panel = rrb.TimePanel(
        timeline="flash_time" if study else "sim_time", play_state="following", state="collapsed"
    )
    return rrb.Blueprint(layout_, time_panel, collapse_panels=True)
