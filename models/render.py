"""Off-screen rendering of both eye cameras, with the exact pixel <-> image-plane mapping.

Pixel convention (verified in tests/test_models_render.py by rendering dots at known 3-D
points): an image is an ``(H, W, 3) uint8`` array, row 0 at the top. Pixel ``(row, col)`` has its
centre at the image-plane point (DESIGN.md, ``z = (x3 + i x1)/x2``)::

    z = ((col - (W - 1)/2) - 1j * (row - (H - 1)/2)) / pixels_per_unit
    pixels_per_unit = f_px = 0.5 * H / tan(fovy / 2)

i.e. the principal point is the geometric image centre ``((W-1)/2, (H-1)/2)`` in (col, row)
pixel-centre coordinates, columns increase with x3 (right) and rows increase with -x1 (down).
MuJoCo's symmetric OpenGL frustum samples pixel centres at ``(col + 0.5)/W`` across the near
plane, which is exactly this mapping (no half-pixel offset).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._gl import GLBackendError, gl_install_hint, mujoco

__all__ = ["EyeImage", "StereoFrame", "EyeRenderer", "EYES", "HIDDEN_GEOM_GROUPS"]

EYES: tuple[str, str] = ("left_eye", "right_eye")
#: Geom groups not drawn in eye images (group 1 = the head's own geoms).
HIDDEN_GEOM_GROUPS: tuple[int, ...] = (1,)


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
        """Image-plane points z (complex) of pixel centres (rows, cols)."""
        cx, cy = self.principal_point
        return ((np.asarray(cols, float) - cx) - 1j * (np.asarray(rows, float) - cy)) / self.pixels_per_unit

    def plane_to_pixel(self, z) -> tuple[np.ndarray, np.ndarray]:
        """(rows, cols) (float) of image-plane points z."""
        z = np.asarray(z, complex)
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


class EyeRenderer:
    """Renders the ``left_eye`` and ``right_eye`` cameras off-screen at ``height x width``.

    Uses one ``mujoco.Renderer`` (one GL context) for both eyes; the head's own geoms (group 1)
    are hidden. Release the context with :meth:`close` (or use as a context manager).
    Raises :class:`GLBackendError` (with the Debian packages to install) if no GL backend works.
    """

    def __init__(self, model: mujoco.MjModel, height: int, width: int | None = None):
        width = height if width is None else width
        if int(height) < 1 or int(width) < 1:
            raise ValueError(f"image size must be positive, got {height}x{width}")
        self.height, self.width = int(height), int(width)
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
        try:
            self._renderer = mujoco.Renderer(model, self.height, self.width)
        except Exception as exc:
            raise GLBackendError(
                f"cannot create an off-screen OpenGL context ({type(exc).__name__}: {exc}). "
                f"Install the backend's Debian packages: {gl_install_hint()}"
            ) from exc

    def render(self, data: mujoco.MjData, depth: bool = False, time_ms: int = 0) -> StereoFrame:
        """Render both eyes for the current state of ``data`` (kinematics must be up to date)."""
        if self._renderer is None:
            raise RuntimeError("renderer is closed")
        out = []
        for eye, cid in zip(EYES, self._cam_ids):
            self._renderer.update_scene(data, camera=cid, scene_option=self._option)
            img = self._renderer.render().copy()
            dep = None
            if depth:
                self._renderer.enable_depth_rendering()
                dep = self._renderer.render().copy()
                self._renderer.disable_depth_rendering()
            fovy = np.deg2rad(self.model.cam_fovy[cid])
            out.append(EyeImage(eye, img, focal_pixels(self.height, fovy), float(fovy),
                                data.cam_xpos[cid].copy(), data.cam_xmat[cid].reshape(3, 3).copy(), dep))
        return StereoFrame(out[0], out[1], int(time_ms))

    def close(self) -> None:
        """Release the GL context (idempotent)."""
        r, self._renderer = getattr(self, "_renderer", None), None
        if r is not None:
            r.close()

    def __enter__(self) -> "EyeRenderer":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass
