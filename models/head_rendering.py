"""Rendering a head's eyes: the renderer, exposures integrated along the eye's trajectory, and the
model's MJCF export (``HeadRendering``, a part of ``models.Head``)."""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from conformal import checks

from ._gl import mujoco
from .build import _path, _write_spec
from .frame_memo import check_megabytes
from .render import EyeRenderer, StereoFrame

__all__ = ["HeadRendering"]


class HeadRendering:
    """The rendering of a ``models.Head`` (which provides ``model``, ``data``, ``spec``, ``image_shape``,
    ``time_ms``, the eye joints' ``_qadr``, the eye cameras' ``_cam_ids`` and ``_command_at``)."""

    # the host's attributes this part uses (declarations for the type checker; ``Head`` sets them)
    model: mujoco.MjModel
    data: mujoco.MjData
    spec: mujoco.MjSpec
    image_shape: tuple[int, int]
    time_ms: int
    _renderer: EyeRenderer | None
    _frame_memo_mb: float
    _qadr: np.ndarray
    _cam_ids: list[int]

    if TYPE_CHECKING:

        def _command_at(self, t_ms: np.ndarray) -> np.ndarray: ...

    @property
    def renderer(self) -> EyeRenderer:
        """The eye renderer (GL context created on first use)."""
        if self._renderer is None:
            self._renderer = EyeRenderer(self.model, *self.image_shape)
            if self._frame_memo_mb > 0:
                self._renderer.remember_frames(self._frame_memo_mb)
        return self._renderer

    def remember_frames(self, megabytes: float = 64.0) -> None:
        """``EyeRenderer.remember_frames`` for this head's renderer: now, or when the renderer is made (no
        GL context is made here; a renderer made again after ``close`` remembers too). 0 turns it off."""
        megabytes = check_megabytes(megabytes)
        self._frame_memo_mb = megabytes
        if self._renderer is not None:
            self._renderer.remember_frames(megabytes)

    def render(self, depth: bool = False, exposure_ms: float = 0.0, samples: int | None = None) -> StereoFrame:
        """Render both eyes now (see :mod:`models.render` for the pixel convention).

        With ``exposure_ms > 0`` the image is the retina's integral over the exposure: the mean of
        ``samples`` renders (default: one per ms, at least 2) at instants spread evenly over
        ``[now, now + exposure_ms)``, each with the eyes where the executed trajectory puts them
        then (the servo tracks it to < 1e-4 deg), the scene as it is now (flashes visible now stay
        visible). A flash during a saccade thus smears along its retinal path as on a real retina
        (at 500 deg/s an 8 ms flash sweeps 4 deg). Time and physics do not advance; the frame's
        camera poses are those at the middle of the exposure; images are rounded to uint8. While
        the eyes hold still over the whole exposure this is the plain render of now.
        """
        depth = checks.flag("depth", depth)
        exposure_ms = checks.real("exposure_ms", exposure_ms, 0.0, 1000.0, hint="milliseconds of integration")
        if exposure_ms == 0:
            if samples is not None:
                raise ValueError("samples applies to an exposure; give exposure_ms > 0")
            return self.renderer.render(self.data, depth=depth, time_ms=self.time_ms)
        n = (
            max(2, int(np.ceil(exposure_ms)))
            if samples is None
            else checks.integer("samples", samples, 1, 1000, hint="renders averaged over the exposure")
        )
        if depth:
            raise ValueError("depth is not defined for an exposure; render depth with exposure_ms=0")
        m, d = self.model, self.data
        qpos, qvel, act = d.qpos.copy(), d.qvel.copy(), d.act.copy()
        times = self.time_ms + (np.arange(n) + 0.5) * exposure_ms / n
        angles = self._command_at(np.append(times, self.time_ms + exposure_ms / 2)).reshape(-1, 6)
        if np.ptp(angles, axis=0).max() == 0.0:  # the eyes hold still: the integral is the image now
            return self.renderer.render(self.data, time_ms=self.time_ms)
        acc, frame = None, None
        try:
            for k in range(n):
                d.qpos[self._qadr] = angles[k]
                mujoco.mj_forward(m, d)
                frame = self.renderer.render(d, time_ms=self.time_ms)
                pair = np.stack([frame.left.image, frame.right.image]).astype(np.float32)
                acc = pair if acc is None else acc + pair
            d.qpos[self._qadr] = angles[n]
            mujoco.mj_forward(m, d)
            poses = [(d.cam_xpos[c].copy(), d.cam_xmat[c].reshape(3, 3).copy()) for c in self._cam_ids]
        finally:
            d.qpos[:], d.qvel[:], d.act[:] = qpos, qvel, act
            mujoco.mj_forward(m, d)
        assert acc is not None and frame is not None, "n >= 1 renders were taken"
        img = np.rint(acc / n).astype(np.uint8)
        eyes = [
            dataclasses.replace(e, image=img[i], camera_position=poses[i][0], camera_xmat=poses[i][1])
            for i, e in enumerate((frame.left, frame.right))
        ]
        return StereoFrame(eyes[0], eyes[1], self.time_ms)

    def export_xml(self, path) -> None:
        """Write this head+scene model as one MJCF file (textures beside it)."""
        path = _path("path", path)
        if path.is_dir():
            raise ValueError(f"path {path} is a folder; give the MJCF file to write, e.g. {path / 'head.xml'}")
        _write_spec(self.spec, path)
