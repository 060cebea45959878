"""Rerun recordings of the whole pipeline on a timeline of simulated milliseconds.

:class:`Recorder` turns the project's objects (``models.Head``, ``StereoFrame``, ``envs.EyeView``,
``conformal.RetinaSamples``, ``models.EyeTrace``) into Rerun archetypes under a stable entity
tree; :func:`record_env_run` records a few saccades of ``envs.BinocularSaccadeEnv``; the
``visualize`` command runs it (``python -m experiments visualize --out run.rrd``; ``--serve`` hosts
the web viewer on 127.0.0.1 with no display needed, :class:`WebViewer`; ``--spawn`` opens a native
viewer and needs a display). The layout is :func:`experiments.blueprint.blueprint`, sent with the
recording (``"run"``; ``"study"`` for the ``conformal_head_study`` app of ``study.rrd``).

Timeline: ``sim_time`` (a duration; simulated time, seconds in Rerun = ms / 1000). In a run of
``visualize`` it is the env's simulated time from its reset. ``study.rrd``
(``experiments.study.record_study``) logs one example trial per flash time t at that trial's own
sim time of the flash, saccade onset + t (the onset comes 210 ms after the trial's reset: 10 ms of
settling and 200 ms of fixation), so its timeline reads t + 210 ms, not the flash time t.

Entity tree (``{eye}`` is ``left`` or ``right``; images are uint8 RGB, or L for grayscale). The 3-D
scene is in metres, world frame z up (``world`` holds ``ViewCoordinates.RIGHT_HAND_Z_UP``, static);
transforms and geoms are logged when first seen and again whenever they change:

===============================================  ==============================================================
``world/scene/{body}``                           a MuJoCo body that has geoms: its world pose (Transform3D from
                                                 ``data.xpos``/``xmat``); ``world`` for the fixed scene, the mocap
                                                 objects (dots, targets, distractors) as they move, the head's
                                                 ``neck``/``head``/``{eye}_eyeball`` bodies as the neck and eyes turn
``world/scene/{body}/{geom}``                    each geom of MuJoCo's visible groups 0-2 (group 1 = the head, which
                                                 the eyes do not see): its pose in the body (Transform3D) and shape
                                                 with its colour (rgba, or the material's colour times its texture's
                                                 mean): box and plane -> Boxes3D (a plane as a 1 mm thick box), sphere
                                                 and ellipsoid -> Ellipsoids3D, capsule -> Capsules3D, cylinder ->
                                                 Cylinders3D, mesh -> Mesh3D. A hidden geom (alpha 0: a flash dot
                                                 that is off) is an empty batch. Unnamed geoms/bodies: ``geom_{id}``
``world/eyes/{eye}/camera``                      the eye camera's world pose (Transform3D: translation =
                                                 ``data.cam_xpos``, mat3x3 = ``data.cam_xmat``, MuJoCo's camera axes
                                                 x right, y up, z back)
``world/eyes/{eye}/camera/image``                Pinhole (f = 0.5 H / tan(fovy/2) px, principal point at the image
                                                 centre, resolution W x H, camera_xyz RUB, image plane drawn 0.3 m
                                                 out) and the eye's rendered image in its frustum (Image)
``world/head/origin``, ``world/head/axes``       head position; its forward (red), left (green), up (blue) axes (Points3D, Arrows3D)
``world/eyes/{eye}/position``                    the eye's nodal point (Points3D)
``world/eyes/{eye}/gaze``                        the optical axis x2 as a ray of ``gaze_length`` m (Arrows3D)
``world/objects``                                the scene's named objects (Points3D with labels, 4 UI points wide)
``world/flashes``                                flashes visible at that instant (Points3D; empty when none)
``eyes/{eye}/image``                             the rendered eye image (H, W, 3)
``eyes/{eye}/grid``                              retina grid overlay: ring circles and sector edges in pixels (LineStrips2D, static)
``eyes/{eye}/target``                            the saccade target's pixel position (Points2D)
``retina/{eye}/fovea``                           foveal samples on their P x P lattice (``conformal.fovea_image``)
``retina/{eye}/logpolar``                        peripheral samples (M, N) [ring, sector]
``dpft/{eye}/log_magnitude``                     log(1 + abs(DPFT)) averaged over colour, (M, N) float32, zero frequency centred (fftshift)
``cortex/left_hemisphere``                       right hemifield of both eyes, (N/2, 2M): left eye | right eye, rows from the upper
                                                 vertical meridian, eccentricity growing to the right within each half
``cortex/right_hemisphere``                      left hemifield of both eyes, (N/2, 2M), same layout
``remap/{eye}/predicted``                        predicted post-saccadic cortical map of one eye (``conformal.cortical_map``, (N/2, 2M)); unknown cells 0
``remap/{eye}/actual``                           the rendered post-saccadic cortical map, (N/2, 2M)
``remap/{eye}/difference``                       abs(predicted - actual) (both clipped to [0, 1]) where both are valid, (N/2, 2M)
``remap/error/{model}``                          normalized RMS error of each remapping model (Scalars)
``flash/true``, ``flash/perceived``              flash positions (x = azimuth_deg, y = -elevation_deg: up is up in the 2-D view) (Points2D)
``flash/shift``                                  arrow from true to perceived (Arrows2D)
``flash/target``, ``flash/fixation``             the saccade target, and the fixation point (0, 0) (static), same frame
``eyes/{eye}/angle/{h,v,t}``                     Fick angles, deg (Scalars; h > 0 right, v > 0 up, t torsion)
``eyes/{eye}/velocity/{h,v,t}``                  joint rates, deg/s (Scalars)
``eyes/{eye}/signal/{h,v,t}``                    the eye-position signal (the brain's estimate), deg (Scalars)
``saccades/{amplitude_deg,peak_velocity_deg_s,duration_ms,endpoint_error_deg}``  per saccade, at its onset (Scalars)
===============================================  ==============================================================

``study.rrd`` holds, at each flash time's instant: the 3-D scene and eyes (``world/...``, from
``log_head`` and ``log_frame``), ``eyes/{eye}/image`` and ``eyes/{eye}/grid`` (no target),
``retina/...``, ``dpft/...``, ``cortex/...`` (``log_views``), ``flash/true``, ``flash/perceived``,
``flash/shift``, ``flash/fixation`` (``log_flash``), ``eyes/{eye}/angle/*`` and ``velocity/*``
(the plan's, ``log_eye_angles``), and, logged by ``record_study`` itself: ``study/true`` and
``study/perceived`` (every trial's positions of that flash time, Points2D, same frame as ``flash/``),
``study/error`` (Arrows2D true -> perceived), ``study/gain`` (the remapping gain at that time) and
``study/compression_index/{A}deg`` (per saccade amplitude A) (Scalars). No ``remap/``,
``saccades/`` or ``eyes/{eye}/target``.

Modules: ``recorder`` (:class:`Recorder`, ``TIMELINE``, ``STUDY_APP_ID``), ``scene_geometry`` (the MuJoCo scene
as ``world/scene/...``), ``images`` (image helpers), ``display`` (whether a native viewer can open),
``web_viewer`` (:class:`WebViewer`), ``env_run`` (:func:`record_env_run`) and ``cli`` (the
``visualize`` command); their public names are re-exported here.
"""

from __future__ import annotations

from .cli import OPTION_BOUNDS, add_subcommand
from .display import display_available
from .env_run import record_env_run
from .images import grid_strips, hemisphere_image, pinhole_matrix
from .recorder import AXIS_NAMES, EYE_NAMES, STUDY_APP_ID, TIMELINE, Recorder
from .scene_geometry import (
    INFINITE_PLANE_HALF_EXTENT,
    PLANE_HALF_THICKNESS,
    POSE_TOLERANCE,
    SCENE_GEOM_GROUPS,
    SceneGeometry,
)
from .web_viewer import WebViewer

__all__ = ["Recorder", "SceneGeometry", "WebViewer", "record_env_run", "add_subcommand", "display_available",
           "EYE_NAMES", "AXIS_NAMES", "TIMELINE", "STUDY_APP_ID",
           "hemisphere_image", "grid_strips", "pinhole_matrix",
           "SCENE_GEOM_GROUPS", "PLANE_HALF_THICKNESS", "INFINITE_PLANE_HALF_EXTENT", "POSE_TOLERANCE",
           "OPTION_BOUNDS"]
