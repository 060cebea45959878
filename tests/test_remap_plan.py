"""The compiled per-frame path: point-map objects, ``RemapPlan`` and the numba kernels, each
against an independent reference (3-D geometry, the direct series sum, scipy's sparse
product, the error formula written out in numpy)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import conformal as C
from conformal import kernels


@pytest.fixture(scope="module")
def grid():
    return C.RetinaGrid.from_field_of_view(0.7, 0.05, 24)


def _maps_for(R, grid, shift=0.3):
    axis = R[:, 1]
    z_target = (axis[2] + 1j * axis[0]) / axis[1]
    return [C.homography_map(R), C.mobius_map(R), C.target_shift_map(z_target, shift, grid.delta)]


def _picture(grid, channels, seed):
    rng = np.random.default_rng(seed)
    u = grid.u[:, None, None]
    th = grid.theta[None, :, None]
    k = rng.uniform(0.5, 2.0, (1, 1, channels))
    f = 0.5 + 0.3 * np.cos(k * 3 * u + th) * np.sin(2 * th + k)  # smooth, so the series means something
    fov = rng.uniform(size=(grid.n_fovea, channels))
    return f, fov


@settings(max_examples=15, deadline=None)
@given(
    axes=st.lists(st.tuples(st.floats(-1, 1), st.floats(-0.3, 0.3), st.floats(-1, 1)), min_size=2, max_size=2),
    angles=st.lists(st.floats(-25, 25), min_size=2, max_size=2),
    channels=st.sampled_from([1, 3]),
)
def test_plan_is_the_series_at_every_mapped_point(grid, axes, angles, channels):
    """Every value the plan predicts is the direct series sum at that map's image of the point
    (periphery), or the foveal samples there (fovea); its mask is where the image is known."""
    Rs = []
    for a, deg in zip(axes, angles):
        if np.linalg.norm(a) < 1e-3:
            a = (0.0, 0.0, 1.0)
        Rs.append(C.rotation_matrix(a, np.radians(deg)))
    pics = [_picture(grid, channels, s) for s in range(2)]
    F = np.stack([C.dpft(f, grid) for f, _ in pics])
    fov = np.stack([fv for _, fv in pics])
    maps = [_maps_for(R, grid) for R in Rs]
    values, valid = C.RemapPlan(grid)(F, fov, maps)
    assert values.dtype == np.float32 and values.shape == (2, 3, grid.n_fovea + grid.M * grid.N, channels)
    z = np.concatenate([grid.fovea_points, grid.points.ravel()])
    for e in range(2):
        for k, pm in enumerate(maps[e]):
            w = pm(z)
            r = np.abs(w)
            known = np.isfinite(w) & (r < grid.ring_edges[-1])
            assert np.array_equal(valid[e, k], known)
            assert np.all(values[e, k][~known] == 0)
            per = known & (r >= grid.r0)
            if per.any():
                ref = C.evaluate_direct(F[e], grid, w[per])
                assert np.abs(values[e, k][per] - ref).max() < 2e-5
            fv = known & (r < grid.r0)
            if fv.any():
                single = C.predict(F[e], fov[e], grid, pm)
                ref_f = np.concatenate([single.fovea, single.periphery.reshape(-1, channels)])[fv]
                assert np.allclose(values[e, k][fv], ref_f, atol=1e-6)


def test_plan_on_a_finer_grid_matches_predict_many(grid):
    fine = C.RetinaGrid.from_field_of_view(0.7, 0.05, 48)
    f, fov = _picture(grid, 3, 5)
    F = C.dpft(f, grid)
    maps = _maps_for(C.rotation_matrix([0.2, 0.1, 1.0], np.radians(10)), grid)
    values, valid = C.RemapPlan(grid, on=fine)(F[None], fov[None], [maps])
    for k, ref in enumerate(C.predict_many(F, fov, grid, maps, on=fine)):
        got = C.RemapPlan(grid, on=fine).samples(values, valid)[0][k]
        assert np.array_equal(got.mask, ref.mask) and np.array_equal(got.fovea_mask, ref.fovea_mask)
        assert np.abs(got.periphery - np.where(ref.mask[..., None], ref.periphery, 0)).max() < 2e-5
        assert np.abs(got.fovea - np.where(ref.fovea_mask[:, None], ref.fovea, 0)).max() < 2e-5


def test_plan_identity_reproduces_the_samples(grid):
    """The identity rotation: the prediction is the retina itself (the series interpolates the samples)."""
    f, fov = _picture(grid, 3, 6)
    F = C.dpft(f, grid)
    values, valid = C.RemapPlan(grid)(F[None], fov[None], [[C.homography_map(np.eye(3)), C.mobius_map(np.eye(3))]])
    assert valid.all()
    inner = np.abs(grid.fovea_points) < grid.r0  # lattice points at the disc's rim fall to the periphery's series
    assert inner.sum() > 20
    for k in range(2):
        assert np.abs(values[0, k, grid.n_fovea:] - f.reshape(-1, 3)).max() < 2e-5
        assert np.allclose(values[0, k, : grid.n_fovea][inner], fov[inner], atol=1e-6)


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda p, F, fv, m: p(F[0], fv, m), "coeffs must be"),
        (lambda p, F, fv, m: p(F, fv[:, :5], m), "fovea must be"),
        (lambda p, F, fv, m: p(F * np.nan, fv, m), "finite"),
        (lambda p, F, fv, m: p(F, fv, m[:1]), "one list of point maps per eye"),
        (lambda p, F, fv, m: p(F, fv, [m[0], m[1][:2]]), "same, non-zero number"),
        (lambda p, F, fv, m: p(F, fv, [m[0], m[1][::-1]]), "same kind"),
        (lambda p, F, fv, m: p(F, fv, [[lambda z: z], [lambda z: z]]), "use predict_many"),
    ],
)
def test_plan_rejects_bad_input_with_a_clear_message(grid, call, message):
    f, fov = _picture(grid, 3, 1)
    F = np.stack([C.dpft(f, grid)] * 2)
    fv = np.stack([fov] * 2)
    maps = [_maps_for(np.eye(3), grid), _maps_for(np.eye(3), grid)]
    with pytest.raises(ValueError, match=message):
        call(C.RemapPlan(grid), F, fv, maps)


def test_homography_sends_directions_behind_the_old_eye_to_nan():
    """An eye turned by 100 deg: the new image's points whose 3-D direction lies behind the old
    eye (x2 <= 0 in old coordinates) were never seen; the rest project as a pinhole does."""
    R = C.rotation_matrix([0.0, 0.0, 1.0], np.radians(100))
    rng = np.random.default_rng(3)
    z = rng.uniform(-1, 1, 200) + 1j * rng.uniform(-1, 1, 200)
    d_old = np.stack([z.imag, np.ones(len(z)), z.real], -1) @ R.T  # (x1, x2, x3) in old coordinates
    behind = d_old[:, 1] <= 0
    assert behind.any() and (~behind).any()
    w = C.homography_map(R)(z)
    assert np.all(np.isnan(w[behind]))
    assert np.allclose(w[~behind], (d_old[~behind, 2] + 1j * d_old[~behind, 0]) / d_old[~behind, 1])


def test_mobius_map_pole_is_nan_and_shift_map_is_affine():
    g = np.array([[1.0, 2.0], [0.5, 2.0]])  # (2 z + 0.5) / (2 z + 1): pole at z = -1/2
    w = C.MobiusMap(g)(np.array([-0.5, 0.0, 1.0 + 1j]))
    assert np.isnan(w[0]) and np.allclose(w[1:], [0.5, (2.5 + 2j) / (3 + 2j)])
    z = np.array([0.1 + 0.2j, -0.3j])
    assert np.allclose(C.target_shift_map(0.2 - 0.1j, 1.5, 0.1)(z), 0.2 - 0.1j + np.exp(0.15) * z)
    with pytest.raises(ValueError, match="3x3"):
        C.ProjectiveMap(np.eye(2))
    with pytest.raises(ValueError, match="2x2"):
        C.MobiusMap(np.full((2, 2), np.nan))


@pytest.mark.parametrize("dtype", [np.uint8, np.float32, np.float64, np.bool_])
@pytest.mark.parametrize("shape", [(40, 48, 3), (40, 48)])
def test_retina_sampling_is_the_sparse_operator_product(dtype, shape):
    g = C.RetinaGrid.from_field_of_view(0.5, 0.05, 16)
    retina = C.Retina(g, shape, 40.0)
    rng = np.random.default_rng(0)
    img = (rng.uniform(size=shape) * (255 if dtype == np.uint8 else 1)).astype(dtype)
    ref = retina.operator @ img.reshape(shape[0] * shape[1], -1).astype(float)
    s = retina.sample(img)
    got = np.concatenate([s.fovea.reshape(g.n_fovea, -1), s.periphery.reshape(g.M * g.N, -1)])
    assert np.allclose(got, ref, rtol=1e-12, atol=1e-12)
    many = retina.sample_many([img, img[::-1].copy()], scale=0.5)
    ref2 = retina.operator @ img[::-1].reshape(shape[0] * shape[1], -1).astype(float)
    assert np.allclose(many[1].reshape(ref2.shape), 0.5 * ref2, rtol=1e-12, atol=1e-12)


def _errors_reference(pred, pred_valid, actual, actual_valid):
    out = np.empty(pred.shape[:2])
    for e in range(pred.shape[0]):
        for k in range(pred.shape[1]):
            m = pred_valid[e, k] & actual_valid
            a, p = actual[e][m].ravel(), pred[e, k][m].ravel()
            if a.size == 0:
                out[e, k] = np.nan
                continue
            contrast = np.sqrt(np.mean((a - a.mean()) ** 2))
            out[e, k] = np.sqrt(np.mean((p - a) ** 2)) / max(contrast, 1e-12)
    return out


def test_normalized_errors_kernel_is_the_formula():
    rng = np.random.default_rng(1)
    pred = rng.uniform(size=(2, 3, 50, 3)).astype(np.float32)
    valid = rng.uniform(size=(2, 3, 50)) < 0.8
    valid[1, 2] = False  # nothing valid: NaN
    actual = rng.uniform(size=(2, 50, 3))
    actual[1, :, :] = 0.25  # constant: the contrast floor applies
    a_valid = rng.uniform(size=50) < 0.9
    out = np.empty((2, 3))
    kernels.normalized_errors(pred, valid, actual, a_valid, out)
    ref = _errors_reference(pred.astype(float), valid, actual, a_valid)
    assert np.isnan(out[1, 2]) and np.isnan(ref[1, 2])
    ok = ~np.isnan(ref)
    assert np.allclose(out[ok], ref[ok], rtol=1e-6)
