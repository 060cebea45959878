"""Fovea transform, hemifield split / cortical maps, Schwartz map, and remapping point maps."""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import conformal as C


@pytest.fixture(scope="module")
def grid():
    return C.RetinaGrid.from_picture(512, 512, 4, 296)


def test_fovea_dft_round_trip_and_euclidean_dft(grid):
    f = np.random.default_rng(0).normal(size=(grid.n_fovea, 3))
    coeffs = C.fovea_dft(f, grid)
    assert np.abs(C.fovea_idft(coeffs, grid) - f).max() < 1e-12
    img = C.fovea_image(f[:, 0], grid)
    # the DC term is the plain sum; a direct 2-D DFT term matches
    assert coeffs[0, 0, 0] == pytest.approx(f[:, 0].sum())
    p = img.shape[0]
    y, x = np.mgrid[:p, :p]
    direct = np.sum(img * np.exp(-2j * np.pi * (2 * y + 3 * x) / p))
    assert coeffs[2, 3, 0] == pytest.approx(direct)


def test_fovea_image_places_samples_upright(grid):
    f = grid.fovea_points.imag  # brighter upwards
    img = C.fovea_image(f, grid, outside=np.nan)
    col = np.nanmean(img, axis=1)
    assert np.all(np.diff(col) < 0)  # row 0 (top) is the largest x1
    assert np.count_nonzero(~np.isnan(img)) == grid.n_fovea


@pytest.mark.slow
def test_fovea_lattice_matches_pixels_in_paper_example(grid):
    # K = 4 dots per unit: each foveal sample is one pixel; sampling a picture reproduces it
    r = C.Retina(grid, (512, 512), 4.0)
    img = np.random.default_rng(1).uniform(size=(512, 512))
    s = r.sample(img)
    z = grid.fovea_points * 4
    rows = np.round(255.5 - z.imag).astype(int)
    cols = np.round(z.real + 255.5).astype(int)
    assert np.allclose(s.fovea, img[rows, cols])


def test_hemifields_route_contralaterally(grid):
    x3 = grid.points.real
    right_only = (x3 > 0).astype(float)  # a stimulus in the right visual field
    rhf, lhf = C.hemifields(right_only, grid)
    assert rhf.shape == (grid.M, grid.N // 2) and np.all(rhf == 1) and np.all(lhf == 0)
    cortex = C.binocular_cortex(right_only, right_only, grid)
    assert np.all(cortex.left_hemisphere == 1) and np.all(cortex.right_hemisphere == 0)
    # both hemifields start at the upper vertical meridian
    upper = C.hemifields(grid.points.imag, grid)
    assert np.all(upper[0][:, 0] > 0) and np.all(upper[1][:, 0] > 0)
    assert np.all(upper[0][:, -1] < 0) and np.all(upper[1][:, -1] < 0)


def test_binocular_cortex_keeps_the_eyes_apart(grid):
    """Different pictures in the two eyes: each hemisphere holds the contralateral hemifield of
    the left eye at eye index 0 and of the right eye at index 1, sample by sample."""
    x3, x1 = grid.points.real, grid.points.imag
    left_eye = 10.0 + x1  # each eye's samples are recognisable by value
    right_eye = -10.0 + x1
    bc = C.binocular_cortex(left_eye, right_eye, grid)
    for hemi, field in ((bc.left_hemisphere, x3 > 0), (bc.right_hemisphere, x3 < 0)):
        assert hemi.shape == (2, grid.M, grid.N // 2)
        for eye, picture in ((0, left_eye), (1, right_eye)):
            assert np.array_equal(np.sort(hemi[eye].ravel()), np.sort(picture[field]))


def test_cortical_map_layout(grid):
    ecc = np.broadcast_to(np.arange(grid.M)[:, None], (grid.M, grid.N)).astype(float)
    cm = C.cortical_map(ecc, grid)
    assert cm.shape == (grid.N // 2, 2 * grid.M)
    assert np.all(cm[:, grid.M - 1] == 0) and np.all(cm[:, grid.M] == 0)  # foveal edges meet
    assert np.all(cm[:, 0] == grid.M - 1) and np.all(cm[:, -1] == grid.M - 1)
    side = np.sign(grid.points.real)
    cm_side = C.cortical_map(side, grid)
    assert np.all(cm_side[:, : grid.M] == -1) and np.all(cm_side[:, grid.M :] == 1)
    img = C.binocular_cortex(ecc, ecc, grid).image()
    assert img.shape == (grid.N, 2 * grid.M)


def test_split_needs_n_divisible_by_four():
    g = C.RetinaGrid.from_field_of_view(1.0, 0.1, 18)
    with pytest.raises(ValueError, match="divisible by 4"):
        C.hemifields(np.zeros((g.M, g.N)), g)


def test_schwartz_map_limits():
    a = 0.5
    small = np.array([1e-4 + 2e-4j, -3e-4 + 1e-4j])
    assert np.allclose(C.schwartz_map(small, a), small / a, rtol=1e-3)  # ~linear near 0
    big = np.array([1e4 * np.exp(0.3j)])
    w = C.schwartz_map(big, a)
    assert abs(w[0] - (np.log(big[0]) - np.log(a))) < 1e-3  # ~ln z far out
    z = np.array([0.3 + 0.7j, 2.0 - 1.0j])
    assert np.allclose(C.schwartz_map(-z.conj(), a), -C.schwartz_map(z, a).conj())  # mirror half-maps
    assert C.schwartz_map(np.array([0j]), a)[0] == 0


@settings(max_examples=40, deadline=None)
@given(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1), st.floats(1e-4, 3.1))
def test_mobius_for_rotation_is_the_sphere_rotated_by_twice_the_angle(a1, a2, a3, angle):
    """The closed form against the 3-D construction: lift to S^2, rotate about (0, 1, 0) about the
    eye's axis by twice its angle, project (``su2_from_rotation``, itself tested by construction)."""
    axis = np.array([a1, a2, a3])
    assume(np.linalg.norm(axis) > 1e-3)
    R = C.rotation_matrix(axis, angle)
    k = C.mobius_for_rotation(R)
    ref = C.su2_from_rotation(C.rotation_matrix(axis, 2 * angle))
    assert np.allclose(k @ k.conj().T, np.eye(2), atol=1e-12) and np.isclose(np.linalg.det(k), 1)
    z = np.array([0.0, 0.3 - 0.2j, -1.5 + 0.7j, 2.0j])
    wk, wr = C.act(k, z), C.act(ref, z)
    fin = np.isfinite(wk) & np.isfinite(wr) & (np.abs(wr) < 1e6)
    assert np.allclose(wk[fin], wr[fin], rtol=1e-8, atol=1e-9)


def test_eye_rotation_maps_send_target_to_fovea():
    R = C.rotation_matrix([0.2, 0.0, 1.0], np.radians(12))  # new axes in old coordinates
    target = C.project(R @ np.array([0.0, 1.0, 0.0]))
    for pm in (C.homography_map(R), C.mobius_map(R)):
        assert np.allclose(pm(np.array([0j])), target, atol=1e-12)
    # the conformal map is conformal, the homography is not: compare local angle distortion
    z0, eps = np.array([0.3 + 0.2j]), 1e-6
    for pm, conformal_expected in ((C.mobius_map(R), True), (C.homography_map(R), False)):
        t1 = (pm(z0 + eps) - pm(z0)) / eps
        t2 = (pm(z0 + 1j * eps) - pm(z0)) / eps
        angle = np.angle(t2 / t1)[0]
        assert (abs(angle - np.pi / 2) < 1e-5) == conformal_expected


def test_predict_identity_and_translation(grid):
    rng = np.random.default_rng(2)
    f = rng.uniform(size=(grid.M, grid.N))
    fov = rng.uniform(size=grid.n_fovea)
    F = C.dpft(f, grid)
    same = C.predict(F, fov, grid, lambda z: z)
    assert np.allclose(same.periphery, f, atol=1e-7)
    assert np.allclose(same.fovea, fov, atol=1e-12) and same.mask.all()
    # a shift map around a target: points mapping beyond r_b are reported, not invented
    shifted = C.predict(F, fov, grid, C.target_shift_map(60.0, 0.0, grid.delta))
    assert not shifted.mask.all() and shifted.mask.any()


def test_predict_many_is_the_series_at_each_maps_points(grid):
    """Two efference copies' maps in one evaluation, in double and single precision: every
    peripheral prediction is the series (direct sum) at its own mapped point, and foveal
    landings are the foveal samples as ``predict`` gives them map by map."""
    rng = np.random.default_rng(4)
    f = rng.uniform(size=(grid.M, grid.N, 3))
    fov = rng.uniform(size=(grid.n_fovea, 3))
    F = C.dpft(f, grid)
    Rs = [C.rotation_matrix([0.1, 0.0, 1.0], np.radians(8)), C.rotation_matrix([1.0, 0.0, 0.3], np.radians(-6))]
    maps = [C.homography_map(Rs[0]), C.mobius_map(Rs[1])]
    for dtype, tol in ((np.float64, 1e-9), (np.float32, 2e-5)):
        out = C.predict_many(F, fov, grid, maps, dtype=dtype)
        for pm, p in zip(maps, out):
            w = pm(grid.points)
            assert np.array_equal(p.mask, np.abs(w) < grid.ring_edges[-1])
            per = p.mask & (np.abs(w) >= grid.r0)
            assert per.sum() > 100
            ref = C.evaluate_direct(F, grid, w[per])
            assert np.abs(p.periphery[per] - ref).max() < tol
            single = C.predict(F, fov, grid, pm)
            assert np.allclose(p.fovea[p.fovea_mask], single.fovea[single.fovea_mask], atol=tol)
