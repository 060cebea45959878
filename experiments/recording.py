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
"""

from __future__ import annotations

import argparse
import math
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.parse
import uuid
from typing import Any, Sequence

import numpy as np
import rerun as rr

import conformal as C

from .blueprint import blueprint

__all__ = ["Recorder", "SceneGeometry", "WebViewer", "record_env_run", "add_subcommand", "display_available",
           "EYE_NAMES", "AXIS_NAMES", "TIMELINE", "STUDY_APP_ID"]

EYE_NAMES = ("left", "right")
AXIS_NAMES = ("h", "v", "t")
TIMELINE = "sim_time"
#: The application id of ``study.rrd``; a Recorder with it gets the ``"study"`` layout.
STUDY_APP_ID = "conformal_head_study"
_AXIS_COLORS = np.array([[220, 50, 50], [50, 180, 50], [60, 90, 230]], np.uint8)
_EYE_COLORS = {"left": [60, 120, 255], "right": [255, 120, 60]}


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


def pinhole_matrix(height: int, width: int, f_px: float) -> np.ndarray:
    """Rerun's ``image_from_camera`` for an eye image: focal length ``f_px`` (= 0.5 H / tan(fovy/2))
    in both axes, principal point at the image centre (W/2, H/2) in Rerun's pixel coordinates
    (pixel centres at +0.5, i.e. ((W-1)/2, (H-1)/2) in ``models.render``'s convention)."""
    return np.array([[f_px, 0.0, width / 2.0], [0.0, f_px, height / 2.0], [0.0, 0.0, 1.0]])


# ---------------------------------------------------------------------- MuJoCo scene -> 3-D entities
#: MuJoCo geom groups drawn in the 3-D view (MuJoCo's visible-by-default groups; 1 = the head).
SCENE_GEOM_GROUPS = (0, 1, 2)
#: A plane is drawn as a box of this half-thickness (m); an infinite plane (size 0) this half-extent.
PLANE_HALF_THICKNESS = 0.0005
INFINITE_PLANE_HALF_EXTENT = 5.0
#: A pose (translation in m, rotation-matrix entries) is logged again once it moved by more than this
#: (Rerun stores them as float32: about 1e-7 at the scale of a metre).
POSE_TOLERANCE = 1e-7
_DEFAULT_GEOM_RGBA = np.array([0.5, 0.5, 0.5, 1.0], np.float32)  # MuJoCo's: a material's colour wins


def _quat_to_mat(q) -> np.ndarray:
    """Unit quaternion (w, x, y, z) -> rotation matrix (child -> parent coordinates)."""
    w, x, y, z = np.asarray(q, float) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _rgba_u8(rgba) -> np.ndarray:
    return (np.clip(np.asarray(rgba, float), 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def _part(name: str, kind: str, i: int) -> str:
    return rr.escape_entity_path_part(name) if name else f"{kind}_{i}"


class SceneGeometry:
    """A MuJoCo model's visible geoms as Rerun entities under ``root`` (default ``world/scene``).

    One entity per body that has geoms, ``{root}/{body}``, holding the body's world pose; one per
    geom, ``{root}/{body}/{geom}``, holding its pose in the body and its shape and colour (see the
    module docstring). :meth:`log` logs what is new or changed since its last call: body poses from
    ``data`` that moved by more than ``POSE_TOLERANCE`` (mocap objects, the turning head and eyes)
    and geoms whose type, size, pose, colour or material changed in the model (a flash switched on
    or off through its alpha, a resized dot).
    Geom types hfield and sdf are not drawn (none of the scenes has them).
    """

    def __init__(self, model, root: str = "world/scene") -> None:
        import mujoco  # imported by models before any model exists

        G = mujoco.mjtGeom
        self._kinds = {int(G.mjGEOM_PLANE): "plane", int(G.mjGEOM_SPHERE): "sphere", int(G.mjGEOM_CAPSULE): "capsule",
                       int(G.mjGEOM_ELLIPSOID): "ellipsoid", int(G.mjGEOM_CYLINDER): "cylinder",
                       int(G.mjGEOM_BOX): "box", int(G.mjGEOM_MESH): "mesh"}
        self._rgb_role = int(mujoco.mjtTextureRole.mjTEXROLE_RGB)
        self.model = model
        m = model
        self.geoms = np.array([g for g in range(m.ngeom) if int(m.geom_group[g]) in SCENE_GEOM_GROUPS
                               and int(m.geom_type[g]) in self._kinds], dtype=int)
        self.bodies = np.unique(m.geom_bodyid[self.geoms]).astype(int) if len(self.geoms) else np.zeros(0, int)
        self.body_paths = {int(b): f"{root}/{_part(m.body(int(b)).name, 'body', int(b))}" for b in self.bodies}
        self.geom_paths = {int(g): self.body_paths[int(m.geom_bodyid[g])] + "/"
                           + _part(m.geom(int(g)).name, "geom", int(g)) for g in self.geoms}
        self._tex_mean: dict[int, np.ndarray] = {}
        self._body_key: np.ndarray | None = None
        self._geom_key: np.ndarray | None = None

    def reset(self) -> None:
        """Forget what was logged: the next :meth:`log` logs everything again."""
        self._body_key = self._geom_key = None

    # ------------------------------------------------------------------ geometry and colour
    def kind(self, gid: int) -> str:
        """``plane``, ``sphere``, ``capsule``, ``ellipsoid``, ``cylinder``, ``box`` or ``mesh``."""
        return self._kinds[int(self.model.geom_type[gid])]

    def _texture_mean(self, tex: int) -> np.ndarray:
        if tex not in self._tex_mean:
            m = self.model
            n = int(m.tex_height[tex]) * int(m.tex_width[tex]) * int(m.tex_nchannel[tex])
            px = np.asarray(m.tex_data[m.tex_adr[tex]:m.tex_adr[tex] + n], float).reshape(-1, int(m.tex_nchannel[tex]))
            rgb = px[:, :3].mean(axis=0) / 255.0 if px.shape[1] >= 3 else np.repeat(px.mean() / 255.0, 3)
            self._tex_mean[tex] = np.append(rgb, 1.0)
        return self._tex_mean[tex]

    def color(self, gid: int) -> np.ndarray:
        """The geom's RGBA as uint8: its ``rgba``, or, when that is MuJoCo's default and it has a
        material, the material's rgba times the mean colour of the material's RGB texture."""
        m = self.model
        rgba = np.asarray(m.geom_rgba[gid], float)
        mat = int(m.geom_matid[gid])
        if mat >= 0 and np.allclose(rgba, _DEFAULT_GEOM_RGBA):
            rgba = np.asarray(m.mat_rgba[mat], float)
            texid = np.atleast_1d(m.mat_texid[mat])
            tex = int(texid[self._rgb_role]) if texid.size > self._rgb_role else int(texid[0])
            if tex >= 0:
                rgba = rgba * self._texture_mean(tex)
        return _rgba_u8(rgba)

    def archetype(self, gid: int):
        """The Rerun shape of geom ``gid`` in its own frame (an empty batch when alpha is 0)."""
        m = self.model
        kind, size, c = self.kind(gid), np.asarray(m.geom_size[gid], float), self.color(gid)
        hidden = c[3] == 0  # alpha 0 (of the geom, or of its material): not drawn by MuJoCo either
        n = 0 if hidden else 1
        if kind in ("box", "plane"):
            half = size.copy()
            if kind == "plane":
                half = np.array([size[0] or INFINITE_PLANE_HALF_EXTENT, size[1] or INFINITE_PLANE_HALF_EXTENT,
                                 PLANE_HALF_THICKNESS])
            return rr.Boxes3D(half_sizes=np.reshape(half, (1, 3))[:n], colors=[c][:n], fill_mode="solid")
        if kind in ("sphere", "ellipsoid"):
            half = np.repeat(size[0], 3) if kind == "sphere" else size
            return rr.Ellipsoids3D(half_sizes=np.reshape(half, (1, 3))[:n], colors=[c][:n], fill_mode="solid")
        if kind == "capsule":  # Rerun's runs from its origin along +z; MuJoCo's is centred
            return rr.Capsules3D(lengths=[2 * size[1]][:n], radii=[size[0]][:n],
                                 translations=[[0.0, 0.0, -size[1]]][:n], colors=[c][:n], fill_mode="solid")
        if kind == "cylinder":
            return rr.Cylinders3D(lengths=[2 * size[1]][:n], radii=[size[0]][:n], centers=[[0.0, 0.0, 0.0]][:n],
                                  colors=[c][:n], fill_mode="solid")
        mesh = int(m.geom_dataid[gid])  # mesh vertices are stored in the geom's frame
        va, vn = int(m.mesh_vertadr[mesh]), int(m.mesh_vertnum[mesh])
        fa, fn = int(m.mesh_faceadr[mesh]), int(m.mesh_facenum[mesh])
        verts = np.asarray(m.mesh_vert[va:va + vn], np.float32)
        faces = np.asarray(m.mesh_face[fa:fa + fn], np.uint32)
        if hidden:
            verts, faces = verts[:0], faces[:0]
        return rr.Mesh3D(vertex_positions=verts, triangle_indices=faces, albedo_factor=c)

    # ------------------------------------------------------------------ logging
    def log(self, rec: rr.RecordingStream, data) -> int:
        """Log new or changed body poses and geoms at ``rec``'s current time; returns how many
        entities were logged."""
        m, n = self.model, 0
        b = self.bodies
        key = np.concatenate([data.xpos[b], data.xmat[b]], axis=1)
        if self._body_key is None:
            self._body_key = key.copy()
            changed = np.ones(len(b), bool)
        else:
            changed = np.any(np.abs(key - self._body_key) > POSE_TOLERANCE, axis=1)
        for i in np.flatnonzero(changed):
            rec.log(self.body_paths[int(b[i])], rr.Transform3D(translation=key[i, :3], mat3x3=key[i, 3:].reshape(3, 3)))
            self._body_key[i] = key[i]
            n += 1
        g = self.geoms
        mat = m.geom_matid[g]
        mat_rgba = np.vstack([np.asarray(m.mat_rgba, float).reshape(-1, 4), np.zeros((1, 4))])  # [-1]: none
        gkey = np.concatenate([m.geom_type[g][:, None], m.geom_size[g], m.geom_pos[g], m.geom_quat[g],
                               m.geom_rgba[g], mat[:, None], mat_rgba[mat]], axis=1)
        changed = np.ones(len(g), bool) if self._geom_key is None else np.any(gkey != self._geom_key, axis=1)
        for i in np.flatnonzero(changed):
            gid = int(g[i])
            path = self.geom_paths[gid]
            rec.log(path, rr.Transform3D(translation=m.geom_pos[gid], mat3x3=_quat_to_mat(m.geom_quat[gid])))
            rec.log(path, self.archetype(gid))
            n += 1
        self._geom_key = gkey
        return n


# ---------------------------------------------------------------------- displays and the web viewer
def display_available() -> bool:
    """Whether a native viewer window can open: on Linux (and the BSDs) ``DISPLAY`` or
    ``WAYLAND_DISPLAY`` must be set; elsewhere assumed."""
    if sys.platform.startswith(("linux", "freebsd", "openbsd", "netbsd")):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True


def _no_display_message(flag: str) -> str:
    return (f"{flag} needs a display (DISPLAY and WAYLAND_DISPLAY are unset); use --serve to view the run in a "
            "web browser, or --out FILE.rrd to write it")


def _rerun_executable() -> str:
    """The ``rerun`` binary of the installed rerun-sdk (not its Python wrapper script, so that
    terminating it stops the server)."""
    if os.environ.get("RERUN_CLI_PATH"):
        return os.environ["RERUN_CLI_PATH"]
    try:
        import rerun_cli

        base = os.path.dirname(rerun_cli.__file__)
        for name in ("rerun", "rerun.exe", os.path.join("Rerun.app", "Contents", "MacOS", "Rerun")):
            if os.path.isfile(os.path.join(base, name)):
                return os.path.join(base, name)
    except ImportError:
        pass
    found = shutil.which("rerun")
    if found:
        return found
    raise FileNotFoundError("the rerun executable was not found; install rerun-sdk (pip install rerun-sdk)")


# Started in the child before exec: it gets SIGTERM when this process dies (Linux), so a killed
# ``visualize --serve`` does not leave the server behind.
_EXEC_WITH_PARENT = (
    "import ctypes, os, signal, sys\n"
    "try:\n"
    "    ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG\n"
    "except Exception:\n"
    "    pass\n"
    "if os.getppid() != int(sys.argv[1]):\n"
    "    sys.exit(1)\n"
    "os.execv(sys.argv[2], sys.argv[2:])\n"
)


def _port_free(port: int, host: str) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        try:
            s.bind((host, port))
        except OSError:
            return False
    return True


def _port_open(port: int, host: str) -> bool:
    try:
        with socket.create_connection((host, port), timeout=0.25):
            return True
    except OSError:
        return False


class WebViewer:
    """Rerun's web viewer and its gRPC proxy (``rerun --serve-web``) in a child process, bound to
    127.0.0.1 only: open :attr:`url` in a browser on this machine (from another one, forward both
    ports, ``ssh -L 9090:127.0.0.1:9090 -L 9876:127.0.0.1:9876 HOST``); stream a recording to
    :attr:`grpc_url` (``Recorder(connect=...)``). The proxy keeps what it received for viewers that
    connect later (up to ``server_memory_limit``). Stop it with :meth:`close` (or use it as a
    context manager); on Linux it also stops when this process dies.

    Raises ``ValueError`` if a port is taken and ``RuntimeError`` if the server does not start.
    """

    HOST = "127.0.0.1"

    def __init__(self, web_port: int = 9090, grpc_port: int = 9876, *, server_memory_limit: str = "1GiB",
                 start_timeout_s: float = 30.0) -> None:
        ports = {"web_port": web_port, "grpc_port": grpc_port}
        for name, port in ports.items():
            if isinstance(port, bool) or not isinstance(port, (int, np.integer)) or not 1 <= port <= 65535:
                raise ValueError(f"{name} must be a whole number in 1..65535; got {port!r}")
        if web_port == grpc_port:
            raise ValueError(f"web_port and grpc_port must differ; both are {web_port}")
        for name, port in ports.items():
            if not _port_free(int(port), self.HOST):
                raise ValueError(f"port {port} on {self.HOST} is in use; choose another ({name})")
        self.web_port, self.grpc_port = int(web_port), int(grpc_port)
        self.proc = None
        self._log = tempfile.TemporaryFile()
        cmd = [_rerun_executable(), "--serve-web", "--bind", self.HOST, "--port", str(self.grpc_port),
               "--web-viewer-port", str(self.web_port), "--server-memory-limit", server_memory_limit]
        if sys.platform.startswith("linux"):
            cmd = [sys.executable, "-c", _EXEC_WITH_PARENT, str(os.getpid()), *cmd]
        self.proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=self._log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + float(start_timeout_s)
        while not (_port_open(self.grpc_port, self.HOST) and _port_open(self.web_port, self.HOST)):
            if self.proc.poll() is not None or time.monotonic() > deadline:
                log = self.output()
                self.close()
                raise RuntimeError(f"the Rerun web viewer did not start on {self.HOST}:{self.web_port} "
                                   f"(gRPC {self.grpc_port}); its output ends: {log[-500:]!r}")
            time.sleep(0.05)

    @property
    def grpc_url(self) -> str:
        """Where a recording streams to (``Recorder(connect=...)``)."""
        return f"rerun+http://{self.HOST}:{self.grpc_port}/proxy"

    @property
    def url(self) -> str:
        """The page to open in a browser: the web viewer, connected to :attr:`grpc_url`."""
        return f"http://{self.HOST}:{self.web_port}/?url={urllib.parse.quote(self.grpc_url, safe='')}"

    @property
    def running(self) -> bool:
        return self.proc.poll() is None

    def output(self) -> str:
        """What the server printed so far."""
        self._log.flush()
        self._log.seek(0)
        return self._log.read().decode(errors="replace")

    def wait(self, seconds: float | None = None) -> None:
        """Serve for ``seconds`` (forever when None; Ctrl-C raises KeyboardInterrupt). Raises
        ``RuntimeError`` if the server stops by itself."""
        deadline = math.inf if seconds is None else time.monotonic() + float(seconds)
        while time.monotonic() < deadline:
            if not self.running:
                raise RuntimeError(f"the Rerun web viewer stopped (exit {self.proc.returncode}); "
                                   f"its output ends: {self.output()[-500:]!r}")
            time.sleep(min(0.2, max(0.0, deadline - time.monotonic())))

    def close(self) -> None:
        """Stop the server (idempotent)."""
        if getattr(self, "proc", None) is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if getattr(self, "_log", None) is not None and not self._log.closed:
            self._log.close()

    def __enter__(self) -> "WebViewer":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:
            pass


# ---------------------------------------------------------------------- the recorder
class Recorder:
    """Log the pipeline to a Rerun recording (see the module docstring for the entity tree).

    ``path`` saves an ``.rrd`` file; ``spawn=True`` opens a native viewer (needs a display);
    ``connect`` streams to a running viewer or proxy (a ``rerun+http://.../proxy`` URL such as
    ``WebViewer.grpc_url``). ``path`` may be combined with either. With none, data is buffered in
    memory and dropped. Call :meth:`set_time_ms` before logging what belongs to an instant, and
    :meth:`close` at the end (or use it as a context manager). ``layout`` picks the blueprint
    (``"run"``, or ``"study"``; default ``"study"`` for ``app_id == STUDY_APP_ID``);
    ``image_plane_distance`` is how far out (m) the 3-D view draws each eye's image in its frustum.
    """

    def __init__(self, path: str | os.PathLike | None = None, *, spawn: bool = False, connect: str | None = None,
                 app_id: str = "conformal_head", recording_id: str | None = None, gaze_length: float = 1.0,
                 image_plane_distance: float = 0.3, layout: str | None = None) -> None:
        if not app_id:
            raise ValueError("app_id must be a non-empty string")
        for name, v in (("gaze_length", gaze_length), ("image_plane_distance", image_plane_distance)):
            if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) \
                    or not (math.isfinite(v) and v > 0):
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
                raise ValueError(f"path {self.path!r} is a directory; give a file such as "
                                 f"{os.path.join(self.path, 'run.rrd')!r}")
        layout = layout or ("study" if app_id == STUDY_APP_ID else "run")
        bp = blueprint(layout)
        self.gaze_length = float(gaze_length)
        self.image_plane_distance = float(image_plane_distance)
        rid = recording_id or str(uuid.uuid4())
        self.rec = rr.RecordingStream(app_id, recording_id=rid)
        self._streaming = spawn or connect is not None
        if self.path is not None:
            os.makedirs(os.path.dirname(os.path.abspath(self.path)), exist_ok=True)
        if self._streaming:
            if spawn:
                rr.spawn(connect=False, recording=self.rec)
            sinks = [rr.GrpcSink(connect) if connect is not None else rr.GrpcSink()]
            if self.path is not None:
                sinks.append(rr.FileSink(self.path))
            self.rec.set_sinks(*sinks, default_blueprint=bp)
        elif self.path is not None:
            self.rec.save(self.path, default_blueprint=bp)
        self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self.t_ms = 0.0
        self._grid_logged: set[str] = set()
        self._scenes: dict[int, tuple[Any, SceneGeometry]] = {}
        self._last: dict[str, np.ndarray] = {}
        self._closed = False

    # ------------------------------------------------------------------ plumbing
    def __enter__(self) -> "Recorder":
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
            self.rec.log(path + "/image", rr.Pinhole(image_from_camera=pinhole_matrix(h, w, f), resolution=[w, h],
                                                     camera_xyz=rr.ViewCoordinates.RUB, color=_EYE_COLORS[eye],
                                                     image_plane_distance=self.image_plane_distance))

    def log_head(self, head) -> None:
        """The scene's geoms and moving bodies, both eye cameras (pose and pinhole), head pose and
        axes, eye positions, gaze rays, scene objects and visible flashes."""
        self.log_scene(head.model, head.data)
        origin = head.to_world(np.zeros(3))
        axes = np.stack([head.to_world(np.eye(3)[i]) - origin for i in range(3)])
        self.rec.log("world/head/origin", rr.Points3D([origin], radii=0.01, colors=[[200, 200, 200]],
                                                      labels=["head"]))
        self.rec.log("world/head/axes", rr.Arrows3D(vectors=0.1 * axes, origins=np.repeat([origin], 3, 0),
                                                    colors=_AXIS_COLORS))
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
            self.rec.log("world/objects", rr.Points3D(pos, radii=rr.components.Radius.ui_points(4.0), labels=names,
                                                      colors=colors))
        visible = list(head.visible_flashes)
        pos = np.stack([head.object_position(n) for n in visible]) if visible else np.zeros((0, 3))
        self.rec.log("world/flashes", rr.Points3D(pos, radii=0.015, colors=[[255, 255, 0]] * len(visible)))

    # ------------------------------------------------------------------ images
    def log_frame(self, frame, grid: C.RetinaGrid, target_px=None) -> None:
        """Both eyes' images (2-D, and in each eye's frustum in 3-D with the camera pose at render
        time); the retina grid overlay (logged once per eye, static); the target.

        ``target_px``: (2, 2) [eye, (row, col)] as from ``Head.project_to_pixels`` (pixel centres
        at integers), or (2, 1, 2) of that, or None.
        """
        tp = None if target_px is None else np.asarray(target_px, float).reshape(2, -1, 2)
        for i, (name, eye) in enumerate(zip(EYE_NAMES, (frame.left, frame.right))):
            img = np.asarray(eye.image)
            self.rec.log(f"eyes/{name}/image", rr.Image(img))
            self.log_eye_camera(name, eye.camera_position, eye.camera_xmat, img.shape[:2], eye.pixels_per_unit)
            self.rec.log(f"world/eyes/{name}/camera/image", rr.Image(img))
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
    def log_eye_angles(self, angles_rad, velocities_rad_s, signal_rad=None) -> None:
        """(2, 3) Fick angles (rad), joint rates (rad/s) and, if given, the eye-position signal
        (rad) at the current time, logged in deg, deg/s."""
        ang = np.degrees(np.asarray(angles_rad, float).reshape(2, 3))
        vel = np.degrees(np.asarray(velocities_rad_s, float).reshape(2, 3))
        sig = None if signal_rad is None else np.degrees(np.asarray(signal_rad, float).reshape(2, 3))
        for e, name in enumerate(EYE_NAMES):
            for j, ax in enumerate(AXIS_NAMES):
                self.rec.log(f"eyes/{name}/angle/{ax}", rr.Scalars(ang[e, j]))
                self.rec.log(f"eyes/{name}/velocity/{ax}", rr.Scalars(vel[e, j]))
                if sig is not None:
                    self.rec.log(f"eyes/{name}/signal/{ax}", rr.Scalars(sig[e, j]))

    def log_eye_trace(self, trace) -> None:
        """All samples of a ``models.EyeTrace`` at their own times (one column batch per series)."""
        if trace is None or len(trace.times_ms) == 0:
            return
        times = rr.TimeColumn(TIMELINE, duration=np.asarray(trace.times_ms, float) / 1000.0)
        series = [("angle", np.degrees(np.asarray(trace.angles, float))),
                  ("velocity", np.degrees(np.asarray(trace.velocities, float)))]
        if trace.eye_position_signal is not None:
            series.append(("signal", np.degrees(np.asarray(trace.eye_position_signal, float))))
        for e, name in enumerate(EYE_NAMES):
            for j, ax in enumerate(AXIS_NAMES):
                for kind, data in series:
                    self.rec.send_columns(f"eyes/{name}/{kind}/{ax}", indexes=[times],
                                          columns=rr.Scalars.columns(scalars=data[:, e, j]))

    def log_saccade(self, plan) -> None:
        """A saccade's amplitude, peak velocity and duration at its onset (the main sequence)."""
        self.rec.set_time(TIMELINE, duration=float(plan.onset_ms) / 1000.0)
        self.rec.log("saccades/amplitude_deg", rr.Scalars(float(plan.amplitude_deg)))
        self.rec.log("saccades/peak_velocity_deg_s", rr.Scalars(math.degrees(plan.peak_velocity)))
        self.rec.log("saccades/duration_ms", rr.Scalars(float(plan.duration_ms)))
        self.rec.log("saccades/endpoint_error_deg", rr.Scalars(float(plan.endpoint_error_deg.mean())))
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
                   remap_model: str = "homography", spawn: bool = False, connect: str | None = None,
                   recording_id: str | None = None, progress: bool = False) -> dict[str, Any]:
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
    only at reset, the flash and the end of each fixation.

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
    env = envs.BinocularSaccadeEnv(scene=scene, task=task, image_size=image_size, fixation_ms=fixation_ms,
                                   shift_rings=shift_rings)
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
            rec.set_time_ms(head.time_ms)
            frame, views = look()
            rec.log_head(head)
            log_images(views, frame)
            rec.log_eye_angles(head.eye_angles, np.zeros((2, 3)), head.eye_position_signal())
            previous = None
            steps_iter = range(int(steps))
            if progress:
                from tqdm import tqdm

                steps_iter = tqdm(steps_iter, unit="saccade", desc="recording")
            for step in steps_iter:
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
#: Bounds of the numeric options of ``visualize`` (inclusive).
OPTION_BOUNDS = {"steps": (1, 100), "seed": (0, 2**32 - 1), "image_size": (16, 1024), "fixation_ms": (1, 10_000),
                 "serve_seconds": (1, 7 * 24 * 3600), "web_port": (1, 65535), "grpc_port": (1, 65535)}


def _whole(lo: int, hi: int):
    """argparse type: a whole number (decimal digits, no exponent or fraction) in ``lo..hi``."""
    def parse(text: str) -> int:
        try:
            v = int(str(text).strip(), 10)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number in {lo}..{hi}; got {text!r}") from None
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"expected a whole number in {lo}..{hi}; got {text!r}")
        return v
    parse.__name__ = "whole number"
    return parse


def _rrd_path(text: str) -> str:
    """argparse type for ``--out``: a file whose folder exists and can be written to."""
    if not str(text).strip():
        raise argparse.ArgumentTypeError("expected a file path such as run.rrd; got ''")
    if "\0" in text:
        raise argparse.ArgumentTypeError(f"the path contains a NUL character: {text!r}")
    path = os.path.abspath(text)
    if os.path.isdir(path):
        raise argparse.ArgumentTypeError(f"{text!r} is a directory; give a file such as "
                                         f"{os.path.join(text, 'run.rrd')!r}")
    parent = os.path.dirname(path)
    if not os.path.isdir(parent):
        raise argparse.ArgumentTypeError(f"folder {parent!r} does not exist (create it first)")
    existed = os.path.exists(path)
    try:
        with open(path, "ab"):
            pass
    except OSError as e:
        raise argparse.ArgumentTypeError(f"cannot write {text!r}: {e.strerror or e}") from None
    if not existed:
        os.remove(path)
    return text


def _run_visualize(args: argparse.Namespace) -> int:
    p = args.parser
    if args.spawn and args.serve:
        p.error("give --spawn or --serve, not both")
    if args.out is None and not (args.spawn or args.serve):
        p.error("give --out FILE.rrd, --serve (web viewer, no display needed) and/or --spawn")
    if args.spawn and not display_available():
        p.error(_no_display_message("--spawn"))
    if args.serve_seconds is not None and not args.serve:
        p.error("--serve-seconds needs --serve")
    viewer = None
    try:
        if args.serve:
            try:
                viewer = WebViewer(args.web_port, args.grpc_port)
            except (ValueError, FileNotFoundError) as e:
                p.error(str(e))
            except RuntimeError as e:
                print(f"python -m experiments visualize: error: {e}", file=sys.stderr)
                return 1
            print(f"Rerun web viewer: {viewer.url}", flush=True)
            print(f"(serving on {viewer.HOST} only, web port {viewer.web_port}, gRPC port {viewer.grpc_port}; "
                  + ("Ctrl-C to stop)" if args.serve_seconds is None else f"for {args.serve_seconds} s after the run)"),
                  flush=True)
        try:
            summary = record_env_run(args.out, steps=args.steps, seed=args.seed, task=args.task, scene=args.scene,
                                     image_size=args.image_size, fixation_ms=args.fixation_ms, spawn=args.spawn,
                                     connect=viewer.grpc_url if viewer is not None else None,
                                     progress=not args.no_progress)
        except (ValueError, FileNotFoundError, KeyError) as e:
            p.error(str(e))
        for i, s in enumerate(summary["saccades"]):
            err = ", ".join(f"{m} {v:.3f}" for m, v in summary["remap_error"][i].items())
            print(f"saccade {i + 1}: {s['amplitude_deg']:.1f} deg, peak {s['peak_velocity_deg_s']:.0f} deg/s, "
                  f"{s['duration_ms']:.0f} ms; remap error {err}")
        where = " and ".join([w for w in (args.out, "the viewer" if args.spawn else None,
                                          "the web viewer" if viewer is not None else None) if w])
        print(f"recorded {summary['start_ms']:.0f}-{summary['end_ms']:.0f} ms of simulated time to {where}", flush=True)
        if viewer is not None:
            try:
                viewer.wait(args.serve_seconds)
            except KeyboardInterrupt:
                print("stopped serving")
            except RuntimeError as e:
                print(f"python -m experiments visualize: error: {e}", file=sys.stderr)
                return 1
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    finally:
        if viewer is not None:
            viewer.close()
    return 0


def add_subcommand(subparsers) -> None:
    """Register ``visualize``: record a run of the environment in Rerun."""
    b = OPTION_BOUNDS
    p = subparsers.add_parser(
        "visualize", help="record a run of the environment in Rerun (--out FILE.rrd, --serve or --spawn)",
        description="Run BinocularSaccade-v0 for a few saccades and record the whole pipeline "
                    "(the head in its scene in 3-D with each eye's camera and image, eye images with the retina "
                    "grid, retina samples, DPFT, cortex, remapping, flashes, eye angles and velocities at every "
                    "physics step) on the sim_time timeline. --serve needs no display: it hosts Rerun's web "
                    "viewer on 127.0.0.1 and prints the address to open.")
    p.add_argument("--out", type=_rrd_path, default=None, help="write the recording to this .rrd file")
    p.add_argument("--spawn", action="store_true", help="open a native Rerun viewer and stream to it (needs a display)")
    p.add_argument("--serve", action="store_true",
                   help="host Rerun's web viewer on 127.0.0.1 (loopback only), stream the run to it, print the "
                        "address to open in a browser and keep serving until Ctrl-C (no display needed)")
    p.add_argument("--serve-seconds", type=_whole(*b["serve_seconds"]), default=None, metavar="S",
                   help="with --serve: stop S seconds after the run is recorded (default: serve until Ctrl-C)")
    p.add_argument("--web-port", type=_whole(*b["web_port"]), default=9090,
                   help="with --serve: port of the web viewer on 127.0.0.1 (default 9090)")
    p.add_argument("--grpc-port", type=_whole(*b["grpc_port"]), default=9876,
                   help="with --serve: port of the gRPC proxy the viewer reads from, on 127.0.0.1 (default 9876)")
    p.add_argument("--steps", type=_whole(*b["steps"]), default=4,
                   help=f"number of saccades (env steps) to record, {b['steps'][0]}..{b['steps'][1]} (default 4)")
    p.add_argument("--seed", type=_whole(*b["seed"]), default=0,
                   help=f"seed of the env and of the saccade choices, {b['seed'][0]}..{b['seed'][1]} (default 0)")
    p.add_argument("--task", choices=("fixate", "search", "free"), default="fixate",
                   help="env task (default fixate)")
    p.add_argument("--scene", choices=("bar", "dots", "natural", "search"), default=None,
                   help="scene (default: the task's; fixate uses dots, which has flashes)")
    p.add_argument("--image-size", type=_whole(*b["image_size"]), default=128,
                   help=f"eye image size in pixels, {b['image_size'][0]}..{b['image_size'][1]} (default 128)")
    p.add_argument("--fixation-ms", type=_whole(*b["fixation_ms"]), default=250,
                   help=f"fixation after each saccade, ms, {b['fixation_ms'][0]}..{b['fixation_ms'][1]} (default 250)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar (it goes to stderr)")
    p.set_defaults(func=_run_visualize, parser=p)
