"""Rerun recordings of the whole pipeline, on timelines of simulated time, flash time and trials.

:class:`Recorder` turns the project's objects (``models.Head``, ``StereoFrame``, ``envs.EyeView``,
``conformal.RetinaSamples``, ``models.EyeTrace``) into Rerun archetypes under a stable entity
tree; :func:`record_env_run` records a few saccades of ``envs.BinocularSaccadeEnv``; the
``visualize`` command runs it (``python -m experiments visualize --out run.rrd``; ``--serve`` hosts
the web viewer on 127.0.0.1 with no display needed, :class:`WebViewer`; ``--spawn`` opens a native
viewer and needs a display). The layout is :func:`experiments.recording.blueprint.blueprint`, sent with the
recording (``"run"``; ``"study"`` for the ``conformal_head_study`` app of ``study.rrd``).

Timelines (:data:`TIMELINES`): ``sim_time`` (a duration: simulated ms, shown in Rerun as seconds =
ms / 1000) in every recording. A run of ``visualize`` adds ``episode`` (0) and ``env_step`` (0 at
reset, k for what is logged during the k-th saccade and its fixation). ``study.rrd``
(``experiments.psychophysics.study.record_study``) adds ``flash_time`` (ms re saccade onset: the time axis of a
perisaccadic experiment) and ``trial`` (trial_id); its ``sim_time`` holds the example trials' flash
instants (saccade onset + t, the onset 210 ms after each trial's reset) for the 3-D replay.

Pictures are scaled to their own range with a documented colour map (:mod:`.colour`,
``PANEL_SCALES``): beside each Image, ``value_range`` (the values at the map's ends) and ``scale``
(``gain``, ``log10``, ``symmetric``) are logged (AnyValues, in the viewer's selection panel).

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
                                                 out) and the eye's rendered image in its frustum (Image, gain-scaled)
``world/head/origin``, ``world/head/axes``       head position; its forward (red), left (green), up (blue) axes (Points3D, Arrows3D)
``world/eyes/{eye}/position``                    the eye's nodal point (Points3D)
``world/eyes/{eye}/gaze``                        the optical axis x2 as a ray of ``gaze_length`` m (Arrows3D)
``world/objects``                                the scene's named objects (Points3D, 4 UI points wide, unlabelled)
``world/labels``                                 the names of the fixation point and the target, each 6 cm above or
                                                 below its object (the higher one's above), so the two never overlap
``world/flashes``                                flashes visible at that instant (Points3D; empty when none)
``eyes/{eye}/image``                             the rendered eye image (H, W, 3), gain-scaled (/ its maximum, hue kept)
``eyes/{eye}/grid``                              retina grid overlay: ring circles and sector edges in pixels (LineStrips2D, static)
``eyes/{eye}/target``                            the saccade target's pixel position (Points2D)
``retina/{eye}/fovea``                           foveal samples on their P x P lattice (``conformal.fovea_image``), gain-scaled
``retina/{eye}/logpolar``                        peripheral samples (M, N) [ring, sector], gain-scaled (gray for a grayscale retina)
``retina/{eye}/flash_response``                  (study) the log-polar response to the flash, flash minus no flash (>= 0), gain, magma
``dpft/{eye}/log_magnitude``                     log10 abs(DPFT) averaged over colour, zero frequency centred (fftshift),
                                                 viridis from its smallest value (at most 3 decades down) to its largest;
                                                 in a study, of the flash response (what the read-out uses)
``cortex/map``                                   both hemispheres in one picture, (N + 2, 2M): the right hemisphere (left
                                                 hemifield of both eyes; left eye | right eye, rows from the upper vertical
                                                 meridian, eccentricity growing outwards) on top, 2 black rows, the left
                                                 hemisphere (right hemifield) below; one gain (magma for a study's flash
                                                 response); ``cortex/labels``: the halves named in words (static)
``remap/{eye}/predicted``                        predicted post-saccadic cortical map of one eye (``conformal.cortical_map``, (N/2, 2M)); unknown cells 0
``remap/{eye}/actual``                           the rendered post-saccadic cortical map, (N/2, 2M); both share one gain
``remap/{eye}/difference``                       predicted - actual (both clipped to [0, 1]) where both are valid, RdBu_r over
                                                 [-m, m] (red: predicted brighter), (N/2, 2M)
``remap/error/{model}``                          normalized RMS error of each remapping model (Scalars)
``flash/true``, ``flash/perceived``              flash positions (x = azimuth_deg, y = -elevation_deg: up is up in the 2-D view) (Points2D)
``flash/shift``                                  arrow from true to perceived (Arrows2D)
``flash/target``, ``flash/fixation``             the saccade target, and the fixation point (static; (0, 0) in a run, (-A/2, 0)
                                                 head-centred in a study), same frame
``eyes/{eye}/angle/{h,v,t}``                     Fick angles, deg (Scalars; h > 0 right, v > 0 up, t torsion)
``eyes/{eye}/velocity/{h,v,t}``                  joint rates, deg/s (Scalars)
``eyes/{eye}/signal/{h,v,t}``                    the eye-position signal (the brain's estimate), deg (Scalars)
``saccades/{amplitude_deg,peak_velocity_deg_s,duration_ms,endpoint_error_deg}``  per saccade, at its onset (Scalars)
===============================================  ==============================================================

``study.rrd`` is made from the study's results folder, not by running trials again: the table and the
example trials' snapshots (``experiments.psychophysics.snapshots``, one trial per flash time of the
amplitude nearest 20 deg). On ``trial``: each trial's ``study/true``, ``study/perceived`` (Points2D,
same frame as ``flash/``, head-centred deg) and ``study/error`` (Arrows2D true -> perceived). On
``flash_time``: the same three for every trial of the example amplitude at that flash time;
``study/compression_index/{A}deg`` and ``study/gain/{A}deg`` (the mean remapping gain) per amplitude
A; the example trial's eye trace ``eyes/{eye}/angle/{h,v}`` and ``eyes/{eye}/signal/{h,v}`` every 2 ms;
and, at each example's flash time (and its flash's ``sim_time``), the 3-D scene posed as at the flash
(``world/...``, the flash in ``world/flashes``), ``eyes/{eye}/image`` and ``eyes/{eye}/grid`` (no
target), ``retina/{eye}/fovea`` and ``logpolar`` (what the retina samples of that image),
``retina/{eye}/flash_response``, ``dpft/...`` and ``cortex/...`` (of the flash response) and
``flash/...`` (the example's flash). No ``remap/``, ``saccades/`` or ``eyes/{eye}/velocity``.

Modules: ``recorder`` (:class:`Recorder`, ``TIMELINE``, ``TIMELINES``, ``STUDY_APP_ID``), ``scene_geometry`` (the
MuJoCo scene as ``world/scene/...``), ``colour`` (colour scales), ``images`` (image helpers), ``display``
(whether a native viewer can open),
``web_viewer`` (:class:`WebViewer`), ``env_run`` (:func:`record_env_run`) and ``cli`` (the
``visualize`` and ``view`` commands); their public names are re-exported here.
"""

from __future__ import annotations

from .cli import OPTION_BOUNDS, add_subcommand
from .display import display_available
from .env_run import record_env_run
from .images import grid_strips, hemisphere_image, pinhole_matrix
from .colour import PANEL_SCALES, colormap_lut, contrast, gain_scaled, log_scaled, symmetric_scaled
from .recorder import AXIS_NAMES, EYE_NAMES, STUDY_APP_ID, TIMELINE, TIMELINES, Recorder
from .scene_geometry import (
    INFINITE_PLANE_HALF_EXTENT,
    PLANE_HALF_THICKNESS,
    POSE_TOLERANCE,
    SCENE_GEOM_GROUPS,
    SceneGeometry,
)
from .web_viewer import WebViewer

__all__ = ["Recorder", "SceneGeometry", "WebViewer", "record_env_run", "add_subcommand", "display_available",
           "EYE_NAMES", "AXIS_NAMES", "TIMELINE", "TIMELINES", "STUDY_APP_ID",
           "PANEL_SCALES", "gain_scaled", "symmetric_scaled", "log_scaled", "colormap_lut", "contrast",
           "hemisphere_image", "grid_strips", "pinhole_matrix",
           "SCENE_GEOM_GROUPS", "PLANE_HALF_THICKNESS", "INFINITE_PLANE_HALF_EXTENT", "POSE_TOLERANCE",
           "OPTION_BOUNDS"]
