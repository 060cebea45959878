"""Off-screen rendering of both eye cameras, with the exact pixel <-> image-plane mapping.

Pixel convention (verified in tests/test_models_render.py by rendering dots at known 3-D
points): an image is an ``(H, W, 3) uint8`` array, row 0 at the top. Pixel ``(row, col)`` has its
centre at the image-plane point (the README's conventions, ``z = (x3 + i x1)/x2``)::

    z = ((col - (W - 1)/2) - 1j * (row - (H - 1)/2)) / pixels_per_unit
    pixels_per_unit = f_px = 0.5 * H / tan(fovy / 2)

i.e. the principal point is the geometric image centre ``((W-1)/2, (H-1)/2)`` in (col, row)
pixel-centre coordinates, columns increase with x3 (right) and rows increase with -x1 (down).
MuJoCo's symmetric OpenGL frustum samples pixel centres at ``(col + 0.5)/W`` across the near
plane, which is exactly this mapping (no half-pixel offset).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from conformal import checks

from ._gl import GLBackendError, gl_install_hint, mujoco
from .frame_memo import FrameMemo, check_megabytes, scene_key

__all__ = ["EyeImage", "StereoFrame", "EyeRenderer", "EYES", "HIDDEN_GEOM_GROUPS", "ForkedGLContextError"]

EYES: tuple[str, str] = ("left_eye", "right_eye")
#: Geom groups not drawn in eye images (group 1 = the head's own geoms).
HIDDEN_GEOM_GROUPS: tuple[int, ...] = (1,)
#: The largest eye image side (pixels).
MAX_IMAGE_SIDE = 4096

#: The id of the process that created an OpenGL context here (None: none yet). Module state is
#: copied into a forked child, where ``os.getpid()`` then differs: the child inherits the parent's
#: GL driver state (EGL threads and locks) but not its threads, and a new context there deadlocks.
_GL_CONTEXT_PID: int | None = None


class ForkedGLContextError(RuntimeError):
    """This process was forked from one that had created an OpenGL context; GL does not survive
    ``fork``, so no context can be created here: start such processes with ``spawn``."""


def _check_not_forked_after_gl() -> None:
    """Raise :class:`ForkedGLContextError` in a forked child of a process that had rendered."""
    if _GL_CONTEXT_PID is not None and _GL_CONTEXT_PID != os.getpid():
        raise ForkedGLContextError(
            f"this process (pid {os.getpid()}) was forked from process {_GL_CONTEXT_PID} after that process had "
            "created an OpenGL context; GL contexts do not survive fork, and rendering here would hang forever. "
            "Start worker processes with the 'spawn' method: gymnasium.make_vec(..., vectorization_mode='async', "
            "vector_kwargs={'context': 'spawn'}), AsyncVectorEnv(..., context='spawn'), "
            "SubprocVecEnv(..., start_method='spawn') or multiprocessing.get_context('spawn')"
        )


@dataclass(frozen=True)
class EyeImage:
    """One eye's rendered image and its pinhole mapping (see the module docstring)."""

    name: str
    image: np.ndarray  #: (H, W, 3) uint8, row 0 = top (largest x1)
    pixels_per_unit: float  #: f_px, pixels per image-plane unit
    fovy: float  #: vertical field of view, radians
    camera_position: np.ndarray  #: (3,) world position of the nodal point
    camera_xmat: np.ndarray  #: (3, 3) MuJoCo camera frame in world (columns: x right, y up, z back)
    depth: np.ndarray | None = None  #: (H, W) metric depth along -z_cam, if requested

    @property
    def shape(self) -> tuple[int, int]:
        return self.image.shape[:2]

    @property
    def principal_point(self) -> tuple[float, float]:
        """(col, row) of the optical axis: ((W-1)/2, (H-1)/2)."""
        h, w = self.shape
        return (w - 1) / 2.0, (h - 1) / 2.0

    def pixel_to_plane(self, rows, cols) -> np.ndarray:
        """Image-plane points z (complex) of pixel centres (rows, cols): finite real arrays that broadcast."""
        cx, cy = self.principal_point
        r = checks.array("rows", rows, kinds="biuf").astype(float)
        c = checks.array("cols", cols, kinds="biuf").astype(float)
        try:
            np.broadcast_shapes(r.shape, c.shape)
        except ValueError:
            raise ValueError(f"rows and cols must have shapes that broadcast; got {r.shape} and {c.shape}") from None
        return ((c - cx) - 1j * (r - cy)) / self.pixels_per_unit

    def plane_to_pixel(self, z) -> tuple[np.ndarray, np.ndarray]:
        """(rows, cols) (float) of finite image-plane points z."""
        z = checks.array("z", z, kinds="biufc").astype(complex)
        cx, cy = self.principal_point
        return cy - z.imag * self.pixels_per_unit, cx + z.real * self.pixels_per_unit


@dataclass(frozen=True)
class StereoFrame:
    """Both eyes' images at one instant (``time_ms`` of simulation time)."""

    left: EyeImage
    right: EyeImage
    time_ms: int

    def __getitem__(self, name: str) -> EyeImage:
        if name in ("left", "left_eye"):
            return self.left
        if name in ("right", "right_eye"):
            return self.right
        raise KeyError(f"no eye {name!r}; use 'left_eye' or 'right_eye'")

    def __iter__(self):
        return iter((self.left, self.right))


def focal_pixels(height: int, fovy: float) -> float:
    """f_px = 0.5 H / tan(fovy/2) (MuJoCo's fovy is vertical)."""
    return 0.5 * height / np.tan(fovy / 2.0)


def _sample_textures_bilinear(renderer: mujoco.Renderer) -> None:
    """Sample every texture of ``renderer``'s GL context at full resolution with bilinear filtering
    (``GL_LINEAR``), as MuJoCo Warp's ray-traced renderer does, instead of MuJoCo's trilinear mipmaps
    (``GL_LINEAR_MIPMAP_LINEAR``, which blur a texture seen from afar): so the single env and the batched
    engine see alike pictures of textured scenes (``tests/test_batched_env.py`` measures them on every
    scene). Reaches the GL texture ids through ``mujoco.Renderer``'s context (``_mjr_context``, tested
    with MuJoCo 4.0)."""
    from OpenGL import GL

    ctx, gl = getattr(renderer, "_mjr_context", None), getattr(renderer, "_gl_context", None)
    if ctx is None or gl is None:
        raise RuntimeError(
            "this MuJoCo's Renderer keeps no _mjr_context/_gl_context: the texture filter cannot "
            "be set (models.render was written for MuJoCo 4.0)"
        )
    gl.make_current()
    for tid, kind in zip(np.asarray(ctx.texture)[: ctx.ntexture], np.asarray(ctx.textureType)[: ctx.ntexture]):
        target = GL.GL_TEXTURE_2D if kind == mujoco.mjtTexture.mjTEXTURE_2D else GL.GL_TEXTURE_CUBE_MAP
        GL.glBindTexture(target, int(tid))
        GL.glTexParameteri(target, GL.GL_TEXTURE_MIN_FILTER, GL.GL_LINEAR)
    GL.glBindTexture(GL.GL_TEXTURE_2D, 0)


class EyeRenderer:
    """Renders the ``left_eye`` and ``right_eye`` cameras off-screen at ``height x width``.

    Uses one ``mujoco.Renderer`` (one GL context) for both eyes; the head's own geoms (group 1)
    are hidden. Release the context with :meth:`close` (or use as a context manager).
    ``height`` and ``width`` are in [1, 4096].
    Raises :class:`GLBackendError` (with the Debian packages to install) if no GL backend works,
    and :class:`ForkedGLContextError` (a ``RuntimeError``) in a process forked from one that had
    already created a GL context (use the ``spawn`` start method).
    """

    def __init__(self, model: mujoco.MjModel, height: int, width: int | None = None):
        global _GL_CONTEXT_PID
        self._renderer = None
        self._memo: FrameMemo | None = None
        if not isinstance(model, mujoco.MjModel):
            raise checks.InputTypeError(f"model must be a mujoco.MjModel; got {type(model).__name__}")
        height = checks.integer("height", height, 1, MAX_IMAGE_SIDE)
        width = height if width is None else checks.integer("width", width, 1, MAX_IMAGE_SIDE)
        self.height, self.width = height, width
        if self.width > model.vis.global_.offwidth or self.height > model.vis.global_.offheight:
            raise ValueError(
                f"image {self.width}x{self.height} exceeds the model's off-screen buffer "
                f"{model.vis.global_.offwidth}x{model.vis.global_.offheight}; build the model with "
                "offscreen_size=(width, height)"
            )
        self.model = model
        self._cam_ids = []
        for eye in EYES:
            cid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, eye)
            if cid < 0:
                raise ValueError(f"model has no camera named {eye!r}")
            self._cam_ids.append(cid)
        self._option = mujoco.MjvOption()
        for g in HIDDEN_GEOM_GROUPS:
            self._option.geomgroup[g] = 0
        _check_not_forked_after_gl()
        try:
            self._renderer = mujoco.Renderer(model, self.height, self.width)
            self._pid = _GL_CONTEXT_PID = os.getpid()
        except Exception as exc:
            raise GLBackendError(
                f"cannot create an off-screen OpenGL context ({type(exc).__name__}: {exc}). "
                f"Install the backend's Debian packages: {gl_install_hint()}"
            ) from exc
        _sample_textures_bilinear(self._renderer)

    def render(self, data: mujoco.MjData, depth: bool = False, time_ms: int = 0) -> StereoFrame:
        """Render both eyes for the current state of ``data`` (kinematics must be up to date)."""
        if self._renderer is None:
            raise RuntimeError("renderer is closed")
        if self._pid != os.getpid():  # a renderer inherited through fork: its context is not usable here
            _check_not_forked_after_gl()
        if not isinstance(data, mujoco.MjData) or data.qpos.shape != (self.model.nq,):
            raise checks.InputTypeError(
                f"data must be the mujoco.MjData of this renderer's model; got {type(data).__name__}"
            )
        depth = checks.flag("depth", depth)
        time_ms = checks.integer("time_ms", time_ms)
        out = []
        memo = self._memo
        for eye, cid in zip(EYES, self._cam_ids):
            self._renderer.update_scene(data, camera=cid, scene_option=self._option)
            key = None if memo is None else scene_key(self._renderer.scene, (cid, depth))
            hit = None if memo is None else memo.get(key)
            if hit is not None:
                img, dep = hit
            else:
                img = self._renderer.render().copy()
                dep = None
                if depth:
                    self._renderer.enable_depth_rendering()
                    dep = self._renderer.render().copy()
                    self._renderer.disable_depth_rendering()
                if memo is not None:
                    memo.put(key, img, dep)
            fovy = np.deg2rad(self.model.cam_fovy[cid])
            out.append(
                EyeImage(
                    eye,
                    img,
                    focal_pixels(self.height, fovy),
                    float(fovy),
                    data.cam_xpos[cid].copy(),
                    data.cam_xmat[cid].reshape(3, 3).copy(),
                    dep,
                )
            )
        return StereoFrame(out[0], out[1], int(time_ms))

    def remember_frames(self, megabytes: float = 64.0) -> None:
        """Keep the frames rendered from now on (up to ``megabytes``, in [0, 4096]; 0 = off) and give a
        frame whose scene was drawn before without drawing it again (``models.frame_memo``: keyed by
        the MuJoCo scene, field by field, so the pixels are those a new render gives). Worth it where
        states repeat (a study's noiseless trials); a cost of ~20 us per eye (reading the scene's fields) where they do not."""
        megabytes = check_megabytes(megabytes)
        self._memo = FrameMemo(megabytes) if megabytes > 0 else None

    def forget_frames(self) -> None:
        """Drop the remembered frames (after uploading new meshes or textures into this context)."""
        if self._memo is not None:
            self._memo.clear()

    @property
    def frame_memo(self) -> FrameMemo | None:
        """The memo of ``remember_frames`` (its ``hits`` and ``misses``), or None."""
        return self._memo

    def close(self) -> None:
        """Release the GL context (idempotent). In a process forked from the one that created it, the
        context is only dropped: freeing it there could hang, and it belongs to the parent."""
        r, self._renderer = getattr(self, "_renderer", None), None
        if r is not None and getattr(self, "_pid", None) == os.getpid():
            r.close()

    def __enter__(self) -> EyeRenderer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass
