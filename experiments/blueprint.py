"""The Rerun blueprint (view layout) sent with every recording of :mod:`experiments.recording`.

Rows, top to bottom: the 3-D scene and both eyes' images with the retina grid; the retinas
(foveal and log-polar samples) and the DPFT log-magnitudes; the cortex (both hemispheres)
and the remapping (predicted, actual, |difference|) of each eye; time series of eye angles
and velocities, remapping errors, the flash positions and each saccade's amplitude, peak
velocity and duration (the main sequence).
"""

from __future__ import annotations

import rerun.blueprint as rrb

__all__ = ["blueprint"]

EYE_NAMES = ("left", "right")


def _image_view(origin: str, name: str) -> rrb.Spatial2DView:
    return rrb.Spatial2DView(origin=origin, contents="$origin/**", name=name)


def blueprint() -> rrb.Blueprint:
    """The layout of the whole pipeline; the time panel shows the ``sim_time`` timeline, following
    the latest data (so a finished recording opens at its end)."""
    eyes = [
        rrb.Spatial2DView(origin=f"eyes/{e}", name=f"{e} eye image + retina grid",
                          contents=[f"eyes/{e}/image", f"eyes/{e}/grid", f"eyes/{e}/target"])
        for e in EYE_NAMES
    ]
    top = rrb.Horizontal(rrb.Spatial3DView(origin="world", name="head and scene"), *eyes,
                         column_shares=[1.2, 1, 1])
    retina = rrb.Grid(
        *[_image_view(f"retina/{e}/fovea", f"{e} fovea") for e in EYE_NAMES],
        *[_image_view(f"retina/{e}/logpolar", f"{e} log-polar [ring, sector]") for e in EYE_NAMES],
        *[_image_view(f"dpft/{e}/log_magnitude", f"{e} DPFT log|F|") for e in EYE_NAMES],
        grid_columns=2,
    )
    cortex = rrb.Vertical(
        _image_view("cortex/right_hemisphere", "right hemisphere (left hemifield; L eye | R eye)"),
        _image_view("cortex/left_hemisphere", "left hemisphere (right hemifield; L eye | R eye)"),
    )
    remap = rrb.Grid(
        *[_image_view(f"remap/{e}/{kind}", f"{e} {kind}")
          for e in EYE_NAMES for kind in ("predicted", "actual", "difference")],
        grid_columns=3,
    )
    middle = rrb.Horizontal(retina, cortex, remap, column_shares=[1, 1, 1.6])
    plots = rrb.Horizontal(
        rrb.TimeSeriesView(origin="eyes", contents=["eyes/*/angle/**"], name="eye angles (deg)"),
        rrb.TimeSeriesView(origin="eyes", contents=["eyes/*/velocity/**"], name="eye velocity (deg/s)"),
        rrb.TimeSeriesView(origin="remap/error", name="remap error (normalized RMS)"),
        rrb.Spatial2DView(origin="flash", name="flash: true (green) vs perceived (red), deg"),
        rrb.TimeSeriesView(origin="saccades", name="saccades: amplitude (deg), peak velocity (deg/s), duration (ms)"),
    )
    layout = rrb.Vertical(top, middle, plots, row_shares=[1.2, 1.3, 1])
    time_panel = rrb.TimePanel(timeline="sim_time", play_state="following", state="collapsed")
    return rrb.Blueprint(layout, time_panel, collapse_panels=True)
