"""Rerun recordings of the whole pipeline, on timelines of simulated time, flash time and trials.

:class:`Recorder` turns the project's objects (``models.Head``, ``StereoFrame``, ``envs.EyeView``,
``conformal.RetinaSamples``, ``models.EyeTrace``) into Rerun archetypes under a stable entity
tree; :func:`record_env_run` records a few saccades of ``envs.BinocularSaccadeEnv``; the
``visualize`` command runs it (``python -m experiments visualize --out run.rrd``; ``--serve`` hosts
the web viewer on 127.0.0.1 with no display needed, :class:`WebViewer`; ``--spawn`` opens a native
viewer and needs a display). The layout is :func:`experiments.recording.blueprint.blueprint`, sent with the
recording (``"run"``; ``"study"`` for the ``conformal_head_study`` app of ``study.rrd``).

The timelines and the entity tree (what is logged where) are in the docs (``docs/rerun.md``,
"Timelines and entity tree").

Modules: ``recorder`` (:class:`Recorder`, ``TIMELINE``, ``TIMELINES``, ``STUDY_APP_ID``), ``scene_geometry`` (the
MuJoCo scene as ``world/scene/...``), ``colour`` (colour scales), ``images`` (image helpers), ``display``
(whether a native viewer can open),
``web_viewer`` (:class:`WebViewer`) and ``env_run`` (:func:`record_env_run`); their public names are
re-exported here. The ``visualize`` and ``view`` commands are ``experiments.cli.visualize`` and ``.view``.
"""

from __future__ import annotations

from .colour import PANEL_SCALES, colormap_lut, contrast, gain_scaled, log_scaled, symmetric_scaled
from .display import display_available
from .env_run import record_env_run
from .images import grid_strips, hemisphere_image, pinhole_matrix
from .recorder import AXIS_NAMES, EYE_NAMES, STUDY_APP_ID, TIMELINE, TIMELINES, Recorder
from .scene_geometry import (
    INFINITE_PLANE_HALF_EXTENT,
    PLANE_HALF_THICKNESS,
    POSE_TOLERANCE,
    SCENE_GEOM_GROUPS,
    SceneGeometry,
)
from .web_viewer import WebViewer

__all__ = [
    "Recorder",
    "SceneGeometry",
    "WebViewer",
    "record_env_run",
    "display_available",
    "EYE_NAMES",
    "AXIS_NAMES",
    "TIMELINE",
    "TIMELINES",
    "STUDY_APP_ID",
    "PANEL_SCALES",
    "gain_scaled",
    "symmetric_scaled",
    "log_scaled",
    "colormap_lut",
    "contrast",
    "hemisphere_image",
    "grid_strips",
    "pinhole_matrix",
    "SCENE_GEOM_GROUPS",
    "PLANE_HALF_THICKNESS",
    "INFINITE_PLANE_HALF_EXTENT",
    "POSE_TOLERANCE",
]
