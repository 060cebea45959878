"""conformal.maps: the point maps written once, one pole rule, the callers' results kept (numpy and torch
to the bit, the fast-math kernel to rounding).

References: each caller's formula as it stood before ``conformal.maps`` (written out below), and the
3-D construction of the maps (lift to the sphere, rotate, project; eq. ``k`` and the pinhole eye).
"""

from __future__ import annotations

import numba as nb
import numpy as np
import pytest

from conformal import act, apply_homography, euler_rotation, k_matrix, maps, rotation_homography
from conformal.kernels import KIND_MOBIUS, KIND_PROJECTIVE, map_points
from conformal.remap import MobiusMap, ProjectiveMap, mobius_params, rotation_matrix

OLD_TOL = 1e-12  # the three copies of _POLE_TOL before conformal.maps


def _points(rng, g=None, n=400):
    """Random image-plane points, with the Moebius map's pole -a/b (and points 1e-13 from it) among them."""
    z = rng.normal(size=n) * 4 + 1j * rng.normal(size=n) * 4
    if g is not None:
        pole = -g[0, 0] / g[0, 1]
        z[:3] = pole, pole + 1e-13, pole - 1e-13j
    return z


def _su2(rng):
    """A random element of SU(2): [[alpha, -conj(beta)], [beta, conj(alpha)]], |alpha|^2 + |beta|^2 = 1."""
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    a, b = q[0] + 1j * q[1], q[2] + 1j * q[3]
    return np.array([[a, -np.conj(b)], [b, np.conj(a)]])


def _rotation(rng):
    return rotation_matrix(rng.normal(size=3), rng.uniform(1.0, 2.5))  # far enough to turn points behind the eye


# ----------------------------------------------------------------------------- the old formulas
def _old_mobius_map(g, z):  # remap.MobiusMap.__call__ before
    a, b, c, d = g.ravel()
    den = b * z + a
    with np.errstate(divide="ignore", invalid="ignore"):
        out = (d * z + c) / den
    return np.where(np.abs(den) >= OLD_TOL, out, np.nan + 0j)


def _old_projective_map(h, z):  # remap.ProjectiveMap.__call__ before
    x, y = z.real, z.imag
    w = h[2, 0] * x + h[2, 1] * y + h[2, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        out = ((h[0, 0] * x + h[0, 1] * y + h[0, 2]) + 1j * (h[1, 0] * x + h[1, 1] * y + h[1, 2])) / w
    return np.where(w > OLD_TOL, out, np.nan + 0j)


def _old_real_mobius(p, x, y):  # the real form in kernels.map_points and batched_vision before
    nr = p[6] * x - p[7] * y + p[4]
    ni = p[6] * y + p[7] * x + p[5]
    dr = p[2] * x - p[3] * y + p[0]
    di = p[2] * y + p[3] * x + p[1]
    return nr * dr + ni * di, ni * dr - nr * di, dr * dr + di * di


def _old_real_homography(p, x, y):  # the same for the homography: numerators and weight
    return p[0] * x + p[1] * y + p[2], p[3] * x + p[4] * y + p[5], p[6] * x + p[7] * y + p[8]


_old_mobius_jit = nb.njit(inline="always")(_old_real_mobius)
_old_homography_jit = nb.njit(inline="always")(_old_real_homography)


@nb.njit(fastmath={"reassoc", "contract", "arcp", "nsz"})
def _old_kernel_maps(zr, zi, kind, p, u, v, ok):  # kernels.map_points' map before, with its flags
    for i in range(zr.shape[0]):
        ok[i] = True
        if kind == 0:
            a, b, w3 = _old_homography_jit(p, zr[i], zi[i])
            if w3 <= OLD_TOL:
                ok[i] = False
            else:
                u[i] = a / w3
                v[i] = b / w3
        else:
            a, b, den = _old_mobius_jit(p, zr[i], zi[i])
            if den < OLD_TOL * OLD_TOL:
                ok[i] = False
            else:
                u[i] = a / den
                v[i] = b / den


def _kernel(kind, params, z):
    """kernels.map_points for one eye and one map, every image kept (r0 tiny, r_outer huge): (w, valid)."""
    n = z.size
    valid = np.zeros((1, 1, n), dtype=bool)
    series = np.zeros_like(valid)
    wr, wi, r2 = np.zeros((1, n)), np.zeros((1, n)), np.zeros((1, n))
    map_points(np.ascontiguousarray(z.real), np.ascontiguousarray(z.imag), np.array([kind]), params[None, None],
               1e-300, 1e300, np.zeros((1, 2, 2, 1)), 1.0, np.zeros((1, 1, n, 1)), valid, series, wr, wi, r2)
    return wr[0] + 1j * wi[0], valid[0, 0]


# ----------------------------------------------------------------------------- bit-identical callers
@pytest.mark.parametrize("seed", range(3))
def test_numpy_callers_keep_their_old_results_to_the_bit(seed):
    rng = np.random.default_rng(seed)
    g = _su2(rng)
    z = _points(rng, g)
    old = _old_mobius_map(g, z)
    assert np.isnan(old[0])  # the pole itself: NaN before and after
    np.testing.assert_array_equal(MobiusMap(g)(z), old)
    np.testing.assert_array_equal(act(g, z[3:]), old[3:])
    with pytest.raises(ValueError, match="sent to infinity"):
        act(g, z[:1])
    h = rotation_homography(_rotation(rng))
    old = _old_projective_map(h, z)
    assert np.isnan(old).any() and not np.isnan(old).all()  # points behind the eye among them
    np.testing.assert_array_equal(ProjectiveMap(h)(z), old)
    seen = ~np.isnan(old)
    np.testing.assert_array_equal(apply_homography(h, z[seen]), old[seen])


@pytest.mark.parametrize("seed", range(3))
def test_the_kernel_keeps_its_old_results(seed):
    """Same points valid, same images up to rounding: the kernel is compiled with fast-math
    (reassociation, contraction), whose last bits depend on the code around a formula."""
    rng = np.random.default_rng(seed)
    g = _su2(rng)
    z = _points(rng, g)
    cases = ((KIND_MOBIUS, mobius_params(g)), (KIND_PROJECTIVE, rotation_homography(_rotation(rng)).ravel()))
    for kind, params in cases:
        u, v, ok = np.zeros(z.size), np.zeros(z.size), np.zeros(z.size, dtype=bool)
        _old_kernel_maps(z.real.copy(), z.imag.copy(), kind, params, u, v, ok)
        w, valid = _kernel(kind, params, z)
        np.testing.assert_array_equal(valid, ok)
        assert not ok.all()  # a pole or points behind the eye among them
        old = (u + 1j * v)[ok]
        assert np.max(np.abs(w[ok] - old) / np.abs(old)) < 64 * np.finfo(float).eps


def test_torch_runs_the_same_body_as_before():
    torch = pytest.importorskip("torch")
    rng = np.random.default_rng(5)
    g = _su2(rng)
    z = _points(rng, g)
    x = torch.tensor(z.real, dtype=torch.float32)
    y = torch.tensor(z.imag, dtype=torch.float32)
    x[0], y[0] = -1.0, 0.0  # the pole of z / (z + 1), exact in float32
    g_pole = np.array([[1.0, 1.0], [0.0, 1.0]])
    cases = ((KIND_MOBIUS, mobius_params(g)), (KIND_MOBIUS, mobius_params(g_pole)),
             (KIND_PROJECTIVE, rotation_homography(_rotation(rng)).ravel()))
    for kind, params in cases:
        pk = [torch.tensor(params[j], dtype=torch.float32).reshape(1, 1) for j in range(9)]
        if kind == KIND_PROJECTIVE:  # envs.batched_vision.evaluate_prechecked before
            a, b, w3 = _old_real_homography(pk, x, y)
            okk = w3 > OLD_TOL
            uu, vv = a / w3, b / w3
            u, v, unseen = maps.homography_point(pk, x, y)
        else:
            a, b, den = _old_real_mobius(pk, x, y)
            okk = den >= OLD_TOL * OLD_TOL
            uu, vv = a / den, b / den
            u, v, unseen = maps.mobius_point(pk, x, y)
        assert torch.equal(~unseen, okk)
        assert params is not cases[1][1] or not bool(okk[0, 0])  # the pole is one
        assert torch.equal(u[okk], uu[okk]) and torch.equal(v[okk], vv[okk])


# ----------------------------------------------------------------------------- the construction
def _sphere_rotation_image(R, z):
    """j(R (j|S^2)^{-1}(z)) written out: lift z to the sphere of centre (0, 1, 0), rotate about the
    centre, project by (x3 + i x1) / x2."""
    t = 2.0 / (1.0 + np.abs(z) ** 2)
    p = np.stack([t * z.imag, t - 1.0, t * z.real], axis=-1)  # minus the centre
    q = p @ R.T
    return (q[:, 2] + 1j * q[:, 0]) / (q[:, 1] + 1.0)


@pytest.mark.parametrize("seed", range(4))
def test_the_moebius_map_is_lift_rotate_project(seed):
    rng = np.random.default_rng(seed)
    angles = rng.uniform(-np.pi, np.pi, size=3)
    k = k_matrix(*angles)  # an SU(2) element: eq. k
    z = _points(rng, n=200)
    expected = _sphere_rotation_image(euler_rotation(*angles), z)
    u, v, pole = maps.mobius_point(mobius_params(k), z.real, z.imag)
    assert not pole.any()
    np.testing.assert_allclose(u + 1j * v, expected, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(maps.mobius(k, z)[0], expected, rtol=1e-9, atol=1e-9)
    w, valid = _kernel(KIND_MOBIUS, mobius_params(k), z)
    assert valid.all()
    np.testing.assert_allclose(w, expected, rtol=1e-9, atol=1e-9)


def test_the_eye_homography_is_rotate_and_project():
    """z_new -> the direction (Im z, 1, Re z) in the new eye, R of it in the old eye, projected."""
    rng = np.random.default_rng(11)
    R = _rotation(rng)
    z = _points(rng, n=200)
    q = np.stack([z.imag, np.ones(z.size), z.real], axis=-1) @ R.T
    seen = q[:, 1] > 0
    expected = (q[:, 2] + 1j * q[:, 0]) / q[:, 1]
    u, v, unseen = maps.homography_point(rotation_homography(R).ravel(), z.real, z.imag)
    np.testing.assert_array_equal(~unseen, seen)
    np.testing.assert_allclose((u + 1j * v)[seen], expected[seen], rtol=1e-9, atol=1e-9)


# ----------------------------------------------------------------------------- the one pole rule
@pytest.mark.filterwarnings("ignore:divide by zero:RuntimeWarning", "ignore:invalid value:RuntimeWarning")
def test_one_pole_rule_in_every_form():
    """|b z + a| < POLE_TOL is a pole, everywhere; 3 POLE_TOL away is not."""
    g = np.array([[1.0, 1.0], [0.0, 1.0]], dtype=complex)  # (z) / (z + 1): pole at z = -1
    z = np.array([-1.0, -1.0 + 0.5 * maps.POLE_TOL, -1.0 + 3 * maps.POLE_TOL, 0.5])
    pole = np.array([True, True, False, False])
    np.testing.assert_array_equal(maps.mobius(g, z)[1], pole)
    np.testing.assert_array_equal(maps.mobius_point(mobius_params(g), z.real, z.imag)[2], pole)
    np.testing.assert_array_equal(np.isnan(MobiusMap(g)(z)), pole)
    np.testing.assert_array_equal(~_kernel(KIND_MOBIUS, mobius_params(g), z)[1], pole)
    with pytest.raises(ValueError, match="sent to infinity"):
        act(g, z[1:2])
    assert np.isfinite(act(g, z[2:])).all()
    # the homography z -> z / (x + 1): its weight is x + 1; behind the eye for x < -1
    h = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 1.0]])
    z = np.array([-2.0, -1.0, -1.0 + 0.5 * maps.POLE_TOL, -1.0 + 3 * maps.POLE_TOL, 0.5])
    unseen = np.array([True, True, True, False, False])
    np.testing.assert_array_equal(maps.homography_point(h.ravel(), z.real, z.imag)[2], unseen)
    np.testing.assert_array_equal(np.isnan(ProjectiveMap(h)(z)), unseen)
    np.testing.assert_array_equal(~_kernel(KIND_PROJECTIVE, h.ravel(), z)[1], unseen)
    with pytest.raises(ValueError, match="sent to infinity"):
        apply_homography(h, z[2:3])
    assert np.isfinite(apply_homography(h, z[np.array([0, 3, 4])])).all()  # a general homography: w3 < 0 is fine


def test_the_tolerance_is_declared_once():
    import conformal

    assert conformal.POLE_TOL is maps.POLE_TOL == 1e-12
    assert maps.POLE_TOL_SQ == maps.POLE_TOL * maps.POLE_TOL
