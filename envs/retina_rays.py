"""Retina-native rendering: rays cast along each receptive field's directions, not through pixels.

MJWarp's batch renderer casts one ray per pixel from a table of directions in the camera frame
(x right, y up, -z forward) that its render context precomputes (``RenderContext.ray``), and with
``samples_per_pixel = s`` it casts s^2 rays per pixel and averages their colours. Here the
"pixels" of each eye camera are the retina's samples (``cam_res = (P, 1)``, P = N_f + M N) and the
table is overwritten with s^2 directions spread over each receptive field, uniform in its area as
the pooled retina (``conformal.Retina``'s ``"pool"``) averages the picture: the peripheral field is
the annular sector r_k <= r < r_(k+1), |phi - theta_l| < pi/N, the foveal field the square of side
1/K. The renderer's average of those rays is the field's sample, so the cost scales with the
retina's samples, not with pixels, and the picture boundary no longer limits the periphery.

``RenderContext.ray`` is an internal field of mujoco-warp, so this module is the one place that
touches it, checked against the renderer's own pinhole rays (``tests/test_retina_rays.py``) and
pinned through the ``gpu`` extra (mujoco-warp 4.0.x).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from conformal import RetinaGrid, checks

__all__ = ["field_ray_directions", "pinhole_ray_directions", "RetinaRenderContext", "MAX_SUBSAMPLES"]

#: The most sub-rays per field side (s; s^2 rays per field).
MAX_SUBSAMPLES = 8


def _strata(s: int) -> NDArray[np.float64]:
    return (np.arange(s) + 0.5) / s


def field_ray_directions(grid: RetinaGrid, subsamples: int = 2) -> NDArray[np.float32]:
    """Unit ray directions in the camera frame (x right, y up, -z forward), (s^2, P, 3) float32:
    for each of the s x s strata (sample-major, as the renderer's table) and each retina sample in
    retina order (the foveal points, then the periphery [k, l] row-major), a point of the field
    uniform in area (the image-plane point z = x + iy gives the direction (x, y, -1) / |.|)."""
    if not isinstance(grid, RetinaGrid):
        raise checks.InputTypeError(f"grid must be a conformal.RetinaGrid; got {type(grid).__name__}")
    s = checks.integer("subsamples", subsamples, 1, MAX_SUBSAMPLES, hint="sub-rays per field side")
    ga, gb = np.meshgrid(_strata(s), _strata(s), indexing="ij")
    a, b = ga.ravel(), gb.ravel()  # (s^2,) stratum centres in [0, 1)^2
    h = grid.fovea_spacing
    zf = grid.fovea_points[None, :] + h * ((a - 0.5)[:, None] + 1j * (b - 0.5)[:, None])
    r1, r2 = grid.ring_edges[:-1], grid.ring_edges[1:]
    r = np.sqrt(r1[None, :] ** 2 + (r2**2 - r1**2)[None, :] * a[:, None])  # uniform in area: r^2 uniform
    phi = grid.theta[None, :] + (b[:, None] - 0.5) * 2 * math.pi / grid.N
    zp = r[:, :, None] * np.exp(1j * phi[:, None, :])  # (s^2, M, N)
    z = np.concatenate([zf, zp.reshape(s * s, -1)], axis=1)
    d = np.stack([z.real, z.imag, -np.ones_like(z.real)], axis=-1)
    return (d / np.linalg.norm(d, axis=-1, keepdims=True)).astype(np.float32)


def pinhole_ray_directions(height: int, width: int, pixels_per_unit: float) -> NDArray[np.float32]:
    """The pinhole camera's pixel-centre rays (H W, 3) in the camera frame, row-major from the top
    row, in the pixel convention of ``models.render`` (z = ((col - (W-1)/2) - i (row - (H-1)/2)) / f_px)."""
    rows, cols = np.mgrid[0:height, 0:width]
    x = (cols - (width - 1) / 2) / pixels_per_unit
    y = -(rows - (height - 1) / 2) / pixels_per_unit
    d = np.stack([x, y, -np.ones_like(x)], axis=-1).reshape(-1, 3)
    return (d / np.linalg.norm(d, axis=-1, keepdims=True)).astype(np.float32)


class RetinaRenderContext:
    """A render context whose every camera renders along ``directions`` (s^2, P, 3) (the same for
    each camera): ``render(m, d)`` then returns each camera's P averaged samples, (N, cameras, P, 3)
    float32 in [0, 1] as a torch tensor on the device."""

    def __init__(
        self, mjm, nworld: int, cam_ids: list[int], directions: NDArray[np.float32], enabled_geom_groups: list[int]
    ) -> None:
        import mujoco_warp as mjw
        import warp as wp

        self._wp, self._mjw = wp, mjw
        n_sub, n_rays = directions.shape[:2]
        s = math.isqrt(n_sub)
        if s * s != n_sub or directions.shape[2:] != (3,):
            raise ValueError(f"directions must be (s^2, P, 3); got {directions.shape}")
        self.n_rays, self.cam_ids = n_rays, list(cam_ids)
        self.rc = mjw.create_render_context(
            mjm,
            nworld=nworld,
            cam_res=[(n_rays, 1)] * len(cam_ids),
            render_rgb=True,
            render_depth=False,
            use_textures=True,
            use_shadows=False,
            enabled_geom_groups=enabled_geom_groups,
            cam_active=self.cam_ids,
            samples_per_pixel=s,
            use_precomputed_rays=True,
        )
        table = np.ascontiguousarray(np.repeat(directions[:, None], len(cam_ids), axis=1).reshape(-1, 3))
        if self.rc.ray.shape != (len(table),):
            raise RuntimeError(
                f"mujoco-warp's render context holds {self.rc.ray.shape} rays, not the {len(table)} "
                "expected: its internal ray layout changed (this module was written for mujoco-warp 4.0)"
            )
        self.rc.ray.assign(table)
        self._out = [wp.zeros((nworld, 1, n_rays), dtype=wp.vec3f) for _ in cam_ids]

    def render(self, m, d):
        import torch

        wp, mjw = self._wp, self._mjw
        mjw.refit_bvh(m, d, self.rc)
        mjw.render(m, d, self.rc)
        for i, out in enumerate(self._out):
            mjw.get_rgb(self.rc, i, out)
        return torch.stack([wp.to_torch(o)[:, 0] for o in self._out], dim=1)
