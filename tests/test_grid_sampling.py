"""Retina grid design rules (§6.2 Example) and pooled sampling against analytic images."""

import math

import numpy as np
import pytest

import conformal as C


@pytest.fixture(scope="module")
def paper_grid():
    return C.RetinaGrid.from_picture(512, 512, 4, 296)


def test_paper_example(paper_grid):
    g = paper_grid
    assert round(g.r0, 3) == 2.427
    assert g.N == 64 and g.M == 37
    assert g.n_samples == 2664 and g.n_fovea == 296 and g.M * g.N == 2368
    # The paper computes delta = ln(10.7084 / 9.7084) from r0 rounded to 2.427 (r0 K = 9.708):
    assert math.log(1 + 1 / (2.427 * 4)) == pytest.approx(0.09804, abs=5e-6)
    # unrounded r0 = sqrt(296/pi)/4 gives the same to the paper's rounding of r0:
    assert g.delta == pytest.approx(math.log(1 + 1 / (math.sqrt(296 / math.pi))), rel=1e-12)
    assert g.delta == pytest.approx(0.09804, abs=2e-5)
    # sample points (2.552 e^{0.09804 k}, (2l + 1) pi / 64)
    assert g.radii[0] == pytest.approx(2.552, abs=1e-3)
    assert np.allclose(np.diff(np.log(g.radii)), g.delta)
    assert np.allclose(g.theta, (2 * np.arange(64) + 1) * np.pi / 64)
    assert g.rb == pytest.approx(g.r0 * math.exp(37 * g.delta))
    # foveal lattice: spacing 1/K, all within ~r0
    fp = g.fovea_points
    assert len(fp) == 296 and len(np.unique(np.round(fp, 9))) == 296
    assert np.abs(fp).max() < g.r0 + 0.5 / 4


def test_paper_example_with_the_papers_rounding_comes_out_exactly():
    """The Example's printed numbers, every one to the digits printed: r0 = 2.427, N = 64,
    delta = 0.09804, M = 37, first sample radius 2.552, 2,664 samples."""
    g = C.RetinaGrid.from_picture(512, 512, dots_per_unit=4, foveal_pixels=296, r0_decimals=3)
    assert g.r0 == 2.427 and g.N == 64 and g.M == 37 and g.n_samples == 2664
    assert round(g.delta, 5) == 0.09804
    assert round(g.radii[0], 3) == 2.552  # r_0 + rho_0 / 2 = r0 (1 + e^delta) / 2
    assert round(math.sqrt(512**2 + 512**2) / 8, 1) == 90.5  # the Example's r_b
    with pytest.raises(ValueError, match="r0_decimals"):
        C.RetinaGrid.from_picture(512, 512, 4, 296, r0_decimals=1.5)


def test_from_angles_covers_field():
    g = C.RetinaGrid.from_angles(40.0, 1.0, 64)
    assert g.r0 == pytest.approx(math.tan(math.radians(1)))
    assert abs(math.log(g.rb / math.tan(math.radians(40)))) <= g.delta / 2 + 1e-12
    # cells at the fovea's edge are about square: radial step ~ arc length
    assert g.r0 * (math.exp(g.delta) - 1) == pytest.approx(2 * math.pi * g.r0 / g.N, rel=0.1)


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(rb=1.0, r0=-0.1),
        dict(rb=0.1, r0=0.2),
        dict(rb=np.nan, r0=0.1),
        dict(rb=1.0, r0=0.1, n_sectors=2),
    ],
)
def test_bad_grid_raises(kwargs):
    with pytest.raises(ValueError):
        C.RetinaGrid.from_field_of_view(**kwargs)


def test_bad_picture_raises():
    with pytest.raises(ValueError):
        C.RetinaGrid.from_picture(16, 16, 1, 10_000)  # fovea bigger than the picture
    with pytest.raises(ValueError):
        C.RetinaGrid.from_picture(512, 512, -4, 296)


@pytest.fixture(scope="module")
def retina_128():
    g = C.RetinaGrid.from_picture(128, 128, 1, 64)
    return C.Retina(g, (128, 128), 1.0)


@pytest.mark.slow
def test_constant_image_samples_to_constant(paper_grid):
    r = C.Retina(paper_grid, (512, 512, 3), 4.0)
    img = np.full((512, 512, 3), 0.37)
    s = r.sample(img)
    assert s.periphery.shape == (37, 64, 3) and s.fovea.shape == (296, 3)
    assert np.allclose(s.periphery[s.mask], 0.37, atol=1e-12)
    assert np.allclose(s.fovea, 0.37, atol=1e-12)
    # the diagonal extent reaches beyond the picture: outer corner cells only partly covered
    assert s.mask[:20].all() and not s.mask.all()


def test_mask_reports_cells_outside_picture():
    g = C.RetinaGrid.from_field_of_view(40.0, 3.0, 32)
    r = C.Retina(g, (40, 100), 1.0)  # wide, short picture
    s = r.sample(np.ones((40, 100)))
    z = g.points
    clearly_out = np.abs(z.imag) - g.radii[:, None] * 0.3 > 20  # centres far above/below
    clearly_in = (np.abs(z.imag) + g.radii[:, None] * 0.3 < 20) & (np.abs(z.real) + g.radii[:, None] * 0.3 < 50)
    assert not s.mask[clearly_out].any()
    assert s.mask[clearly_in].all()
    assert np.all(s.periphery[~s.mask & (r.coverage[g.n_fovea:].reshape(g.M, g.N) == 0)] == 0)


def test_pooled_samples_equal_exact_cell_averages_of_radial_image():
    # f = cos(a r^2) has exact ring averages: int cos(a r^2) r dr = sin(a r^2) / (2a).
    g = C.RetinaGrid.from_picture(256, 256, 1, 50, extent="inscribed")
    a = 2e-3  # local frequency a r / pi stays below 0.12 cycles per pixel in the picture
    z = C.pixel_points((256, 256), 1.0)
    r = C.Retina(g, (256, 256), 1.0, supersample=8)
    s = r.sample(np.cos(a * np.abs(z) ** 2))
    e = g.ring_edges
    exact = (np.sin(a * e[1:] ** 2) - np.sin(a * e[:-1] ** 2)) / (a * (e[1:] ** 2 - e[:-1] ** 2))
    full = r.coverage[g.n_fovea :].reshape(g.M, g.N) > 0.99  # cells (all but) wholly inside the picture
    assert full.sum() > 0.6 * g.M * g.N
    err = np.abs(s.periphery - exact[:, None])[full]
    assert err.max() < 0.01
    # point sampling at the cell centre misses the average in the large outer cells
    rp = C.Retina(g, (256, 256), 1.0, mode="bilinear")
    sp_ = rp.sample(np.cos(a * np.abs(z) ** 2))
    assert np.abs(sp_.periphery - exact[:, None])[full].max() > 10 * err.max()


def test_checkerboard_samples_to_mean_in_periphery(paper_grid):
    r = C.Retina(paper_grid, (512, 512), 4.0)
    yy, xx = np.mgrid[:512, :512]
    cb = ((xx // 2 + yy // 2) % 2).astype(float)  # 2-pixel checkerboard
    s = r.sample(cb)
    cell_px = paper_grid.radii * paper_grid.delta * 4  # radial cell size in pixels
    big = cell_px > 8
    assert np.all(np.abs(s.periphery[big][s.mask[big]] - 0.5) < 0.05)
    rn = C.Retina(paper_grid, (512, 512), 4.0, mode="nearest")
    sn = rn.sample(cb)
    assert np.abs(sn.periphery[big][sn.mask[big]] - 0.5).min() == pytest.approx(0.5)  # aliases to 0 or 1


def test_bilinear_point_sampling_is_exact_on_linear_image(retina_128):
    g = retina_128.grid
    rp = C.Retina(g, (128, 128), 1.0, mode="bilinear")
    z = C.pixel_points((128, 128), 1.0)
    img = 2.0 + 0.1 * z.real - 0.05 * z.imag
    s = rp.sample(img)
    expected = 2.0 + 0.1 * g.points.real - 0.05 * g.points.imag
    interior = (np.abs(g.points.real) < 63) & (np.abs(g.points.imag) < 63)  # between pixel centres
    assert interior.sum() > 100
    assert np.allclose(s.periphery[interior], expected[interior], atol=1e-9)


def test_render_back_shows_cell_values(retina_128):
    img = np.full((128, 128), 3.0)
    s = retina_128.sample(img)
    back = retina_128.render(s, background=-1)
    assert back.shape == (128, 128)
    assert np.allclose(back, 3.0)  # the inscribed-or-larger grid covers every pixel here


def test_render_back_puts_each_cell_where_its_geometry_is(retina_128):
    """Cell values k * N + l rendered back: every peripheral pixel shows the ring and sector
    computed from its own radius and angle (ln(r / r0) / delta, theta N / 2 pi)."""
    g = retina_128.grid
    per = np.arange(g.M * g.N, dtype=float).reshape(g.M, g.N)
    fov = -1.0 - np.arange(g.n_fovea)
    back = retina_128.render(C.RetinaSamples(fov, per, np.ones((g.M, g.N), bool), np.ones(g.n_fovea, bool)),
                             background=-1e9)
    z = C.pixel_points((128, 128), retina_128.pixels_per_unit)
    ring = np.floor(np.log(np.abs(z) / g.r0) / g.delta)
    sector = np.floor(np.mod(np.angle(z), 2 * np.pi) / (2 * np.pi / g.N))
    inside = (ring >= 0) & (ring < g.M)
    # away from cell borders (floating point decides the border pixels either way)
    frac_r = np.log(np.abs(z) / g.r0) / g.delta - ring
    frac_s = np.mod(np.angle(z), 2 * np.pi) / (2 * np.pi / g.N) - sector
    clear = inside & (np.minimum(frac_r, 1 - frac_r) > 1e-6) & (np.minimum(frac_s, 1 - frac_s) > 1e-6)
    assert clear.sum() > 0.5 * inside.sum()
    assert np.array_equal(back[clear], (ring * g.N + sector)[clear])
    fovea = np.abs(z) < g.r0 - g.fovea_spacing
    assert np.all(back[fovea] < 0) and np.all(back[fovea] > -1e9)  # foveal samples, not background
    # the nearest foveal sample: the lattice point closest to the pixel
    fp = g.fovea_points
    nearest = np.argmin(np.abs(z[fovea][:, None] - fp[None, :]), axis=1)
    assert np.array_equal(back[fovea], fov[nearest])


@pytest.mark.parametrize(
    "image",
    [np.zeros((64, 64)), np.zeros((128, 128, 2)), np.full((128, 128), np.nan), np.zeros((128, 128), dtype=complex)],
)
def test_bad_images_raise(retina_128, image):
    with pytest.raises(ValueError):
        retina_128.sample(image)


def test_bad_retina_parameters_raise(paper_grid):
    with pytest.raises(ValueError):
        C.Retina(paper_grid, (512, 512), 0.0)
    with pytest.raises(ValueError):
        C.Retina(paper_grid, (512, 512), 4.0, mode="cubic")
