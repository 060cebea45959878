"""Retina-native rendering (``envs.retina_rays``): the wrapper of mujoco-warp's internal ray table
checked against the renderer's own pinhole rays, the sub-rays against the receptive fields'
geometry, and the rendered samples against the pooled samples of a fine pinhole picture."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("mujoco_warp")

import models  # noqa: E402  (before mujoco_warp: the GL backend)
import conformal as C  # noqa: E402
from envs import Vision  # noqa: E402
from envs.retina_rays import RetinaRenderContext, field_ray_directions, pinhole_ray_directions  # noqa: E402

import warp as wp  # noqa: E402
import mujoco_warp as mjw  # noqa: E402

GROUPS = [0, 2, 3, 4, 5]
#: Warp's device for these tests: its CPU backend unless CONFORMAL_TEST_DEVICE names another (cuda).
DEVICE = os.environ.get("CONFORMAL_TEST_DEVICE", "cpu")


def _warp_world(head):
    m = mjw.put_model(head.model)
    d = mjw.make_data(head.model, nworld=1)
    d.qpos.assign(head.data.qpos[None].astype(np.float32))
    d.mocap_pos.assign(head.data.mocap_pos[None].astype(np.float32))
    d.mocap_quat.assign(head.data.mocap_quat[None].astype(np.float32))
    mjw.forward(m, d)
    return m, d


def test_pinhole_rays_are_the_renderers_own():
    """Ground truth: the rays mujoco-warp precomputes for a pinhole camera (its own projection code).
    Our table convention (camera frame, row-major from the top row, models.render's pixel mapping)
    must reproduce them, or the retina's rays would land elsewhere than we think."""
    head = models.Head("dots", image_size=(48, 64), seed=0)
    with wp.ScopedDevice(DEVICE):
        rc = mjw.create_render_context(head.model, nworld=1, cam_res=(64, 48), render_rgb=True, render_depth=False,
                                       enabled_geom_groups=GROUPS, cam_active=[0, 1])
        theirs = rc.ray.numpy()
    ours = pinhole_ray_directions(48, 64, head.pixels_per_unit)
    np.testing.assert_allclose(ours, theirs[: 48 * 64], atol=1e-6)  # measured 1.2e-7 (float32)
    np.testing.assert_allclose(ours, theirs[48 * 64:], atol=1e-6)  # the second camera's: the same table


def test_sub_rays_cover_each_field_uniformly():
    grid = C.RetinaGrid.from_field_of_view(0.6, 0.05, 24)
    s = 8
    d = field_ray_directions(grid, s).astype(np.float64)
    assert d.shape == (s * s, grid.n_fovea + grid.M * grid.N, 3)
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, atol=1e-6)
    z = (d[..., 0] + 1j * d[..., 1]) / -d[..., 2]  # back to the image plane
    zf, zp = z[:, : grid.n_fovea], z[:, grid.n_fovea:].reshape(s * s, grid.M, grid.N)
    h = grid.fovea_spacing
    off = zf - grid.fovea_points[None]
    assert np.all(np.abs(off.real) < h / 2 + 1e-6) and np.all(np.abs(off.imag) < h / 2 + 1e-6)
    r = np.abs(zp)
    e = grid.ring_edges
    assert np.all(r >= e[:-1, None] * (1 - 1e-6)) and np.all(r <= e[1:, None] * (1 + 1e-6))
    dphi = np.angle(zp * np.exp(-1j * grid.theta)[None, None, :])
    assert np.all(np.abs(dphi) <= math.pi / grid.N + 1e-6)
    # uniform in area: the sub-rays' mean radius approaches the sector's centroid radius
    # E[r] = 2 (r2^3 - r1^3) / (3 (r2^2 - r1^2)) (exact for a uniform density on the annulus)
    r1, r2 = e[:-1], e[1:]
    centroid_r = 2 * (r2**3 - r1**3) / (3 * (r2**2 - r1**2))
    np.testing.assert_allclose(r.mean(axis=(0, 2)), centroid_r, rtol=2e-3)


def test_native_samples_match_a_fine_pooled_picture():
    """Bar scene (untextured): the retina rendered along 4x4 sub-rays per field against the pooled
    samples of a 256 px pinhole picture (the CPU env's path at a resolution where pixels are much
    smaller than the fields). Measured mean / max |difference|: 1 ray per field 0.015 / 0.23, 2x2
    0.0066 / 0.11, 4x4 0.0042 / 0.044: the rays converge on the field average (what remains: the
    reference's own pixel quantisation at the bars' edges and the two renderers' shading)."""
    head = models.Head("bar", image_size=256, seed=0)
    head.reset()
    vision = Vision(head.image_shape, head.pixels_per_unit, fovea_deg=4.0, n_sectors=24)
    frame = head.render()
    ref = np.stack([v.samples for v in vision.see_eyes((frame.left.image, frame.right.image))])
    diffs = {}
    with wp.ScopedDevice(DEVICE):
        m, d = _warp_world(head)
        for s in (1, 4):
            rr = RetinaRenderContext(head.model, 1, [0, 1], field_ray_directions(vision.grid, s), GROUPS)
            native = rr.render(m, d)[0].cpu().numpy()
            assert native.shape == ref.shape
            diffs[s] = np.abs(native - ref)
    assert diffs[4].mean() < 0.008 and diffs[4].max() < 0.08, (diffs[4].mean(), diffs[4].max())
    assert diffs[4].mean() < 0.5 * diffs[1].mean()  # more rays per field: closer to the field's average


def test_bad_arguments():
    grid = C.RetinaGrid.from_field_of_view(0.6, 0.05, 24)
    with pytest.raises(ValueError, match="subsamples"):
        field_ray_directions(grid, 0)
    with pytest.raises(TypeError, match="RetinaGrid"):
        field_ray_directions("grid", 2)


pytestmark = pytest.mark.warp  # needs the gpu extra (Warp, MuJoCo Warp, torch): see the README's "Tests"
