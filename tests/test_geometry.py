"""Geometry of the conformal camera checked against 3-D constructions (paper §3-4)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import conformal as C

angles = st.floats(-np.pi, np.pi, allow_nan=False)
small = st.floats(-2.0, 2.0, allow_nan=False)


def rand_z(rng, n=20):
    return rng.normal(size=n) + 1j * rng.normal(size=n)


def rot_about_axis(axis, angle):
    """Independent Rodrigues construction (not the library's)."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def sphere_rotation_by_construction(R, z):
    """Lift z onto S^2 centred at (0,1,0) by intersecting the ray with the sphere, rotate
    about the centre, and project by j -- all written out here from scratch."""
    v = np.stack([z.imag, np.ones_like(z.real), z.real], -1)  # (x1, x2, x3) on x2 = 1
    c = np.array([0.0, 1.0, 0.0])
    # |t v - c|^2 = 1  ->  t^2 |v|^2 - 2 t v.c = 0
    t = 2 * (v @ c) / np.sum(v * v, -1)
    p = t[:, None] * v
    q = (p - c) @ R.T + c
    return (q[:, 2] + 1j * q[:, 0]) / q[:, 1]


def test_projection_and_lift_roundtrip():
    rng = np.random.default_rng(0)
    z = rand_z(rng)
    p = C.lift_to_sphere(z)
    assert np.allclose(np.linalg.norm(p - C.SPHERE_CENTRE, axis=-1), 1.0, atol=1e-12)
    assert np.allclose(C.project(p), z, atol=1e-12)
    pts = np.c_[rng.normal(size=5), rng.uniform(0.5, 2, 5), rng.normal(size=5)]
    assert np.allclose(C.project(pts), (pts[:, 2] + 1j * pts[:, 0]) / pts[:, 1])


@settings(max_examples=60, deadline=None)
@given(angles, st.floats(0.0, np.pi, allow_nan=False), angles)
def test_k_matrix_is_sphere_rotation(psi, phi, psi2):
    # R(psi, phi, psi') = rotations about x2, then about the x3-parallel axis through the
    # centre, then about the rotated x2 axis (intrinsic), each clockwise seen along the axis.
    R = rot_about_axis([0, 1, 0], -psi) @ rot_about_axis([0, 0, 1], -phi) @ rot_about_axis([0, 1, 0], -psi2)
    z = rand_z(np.random.default_rng(1))
    k = C.k_matrix(psi, phi, psi2)
    assert np.allclose(k @ k.conj().T, np.eye(2), atol=1e-12)
    w_expected = sphere_rotation_by_construction(R, z)
    ok = np.abs(w_expected) < 1e6
    assert np.allclose(C.act(k, z[ok]), w_expected[ok], rtol=1e-9, atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(small, st.floats(-0.9, 3.0, allow_nan=False), small)
def test_h_matrix_is_translation(b1, b2, b3):
    z = rand_z(np.random.default_rng(2))
    v = np.stack([z.imag, np.ones(len(z)), z.real], -1) + np.array([b1, b2, b3])
    expected = (v[:, 2] + 1j * v[:, 0]) / v[:, 1]
    h = C.h_matrix(b1, b2, b3)
    assert abs(np.linalg.det(h) - 1) < 1e-12
    assert np.allclose(C.act(h, z), expected, rtol=1e-9, atol=1e-9)


def test_h_matrix_behind_the_camera():
    # 1 + b2 < 0: the paper's epsilon-coset; still the projected translation.
    z = rand_z(np.random.default_rng(3))
    h = C.h_matrix(0.3, -2.5, -0.2)
    assert np.allclose(C.act(h, z), (z - 0.2 + 0.3j) / (1 - 2.5))


def test_composition_and_inverse_are_group_operations():
    rng = np.random.default_rng(4)
    z = rand_z(rng)
    g1, g2 = C.k_matrix(0.3, 1.1, -0.4), C.h_matrix(0.2, 0.5, -0.7)
    assert np.allclose(C.act(C.compose(g1, g2), z), C.act(g1, C.act(g2, z)))
    assert np.allclose(C.act(C.inverse(g2), C.act(g2, z)), z)
    # eq. IPT: g^{-1} . z = (a z - c)/(-b z + d)
    (a, b), (c, d) = g2
    assert np.allclose(C.act(C.inverse(g2), z), (a * z - c) / (-b * z + d))


def test_transform_image_moves_a_feature():
    g = C.h_matrix(0.0, 0.0, 0.5)  # translation by +0.5 along x3
    f = lambda z: np.exp(-np.abs(z) ** 2 / 0.01)  # blob at 0
    fg = C.transform_image(f, g)
    assert fg(np.array([0.5 + 0j]))[0] == pytest.approx(1.0)
    assert fg(np.array([0j]))[0] < 1e-6


@settings(max_examples=30, deadline=None)
@given(angles, st.floats(0.0, np.pi), angles, small, st.floats(-0.5, 2), small)
def test_conformality_angles_preserved(psi, phi, psi2, b1, b2, b3):
    g = C.compose(C.k_matrix(psi, phi, psi2), C.h_matrix(b1, b2, b3))
    q = 0.3 - 0.2j
    if abs(g[0, 1] * q + g[0, 0]) < 1e-3:
        return
    eps = 1e-6
    d1, d2 = np.exp(0.4j), np.exp(1.9j)
    w0 = C.act(g, np.array([q]))[0]
    t1 = (C.act(g, np.array([q + eps * d1]))[0] - w0) / eps
    t2 = (C.act(g, np.array([q + eps * d2]))[0] - w0) / eps
    assert np.angle(t2 / t1) == pytest.approx(1.5, abs=1e-4)


def test_circles_map_to_circles():
    rng = np.random.default_rng(5)
    g = C.compose(C.k_matrix(0.7, 2.0, 0.1), C.h_matrix(0.4, 0.3, -0.2))
    centre, radius = 0.2 + 0.1j, 0.5
    w = C.act(g, centre + radius * np.exp(1j * rng.uniform(0, 2 * np.pi, 12)))
    # fit a circle through three image points, check all others lie on it
    a, b, c = w[:3]
    A = np.array([[2 * (b - a).real, 2 * (b - a).imag], [2 * (c - a).real, 2 * (c - a).imag]])
    rhs = np.array([abs(b) ** 2 - abs(a) ** 2, abs(c) ** 2 - abs(a) ** 2])
    cx, cy = np.linalg.solve(A, rhs)
    r = np.abs(w - (cx + 1j * cy))
    assert np.allclose(r, r[0], rtol=1e-8)


def test_su2_from_rotation_matches_construction():
    rng = np.random.default_rng(6)
    z = rand_z(rng)
    for _ in range(10):
        R = rot_about_axis(rng.normal(size=3), rng.uniform(0, np.pi))
        k = C.su2_from_rotation(R)
        assert np.allclose(C.act(k, z), sphere_rotation_by_construction(R, z), atol=1e-9)
        assert np.allclose(C.rotation_from_su2(k), R, atol=1e-9)


def test_rotation_homography_matches_pinhole_construction():
    rng = np.random.default_rng(7)
    R = rot_about_axis([0.3, 0.1, 1.0], 0.4)  # new eye axes in old coordinates
    z_new = 0.3 * rand_z(rng)
    d_new = np.stack([z_new.imag, np.ones(len(z_new)), z_new.real], -1)
    d_old = d_new @ R.T
    expected = (d_old[:, 2] + 1j * d_old[:, 0]) / d_old[:, 1]
    assert np.allclose(C.homography_map(R)(z_new), expected)


@pytest.mark.parametrize(
    "call",
    [
        lambda: C.act(np.array([[2, 0], [0, 1]]), 1j),  # det 2
        lambda: C.act(np.eye(2), np.nan),
        lambda: C.act(np.eye(2), np.inf),
        lambda: C.act(np.array([[0, 1], [-1, 0]]), 0.0),  # sent to infinity
        lambda: C.project([1.0, 0.0, 2.0]),  # x2 = 0
        lambda: C.h_matrix(0, -1, 0),
        lambda: C.k_matrix(np.nan, 0, 0),
        lambda: C.act(np.eye(3), 1.0),
        lambda: C.su2_from_rotation(np.diag([1, 1, -1.0])),
    ],
)
def test_bad_input_raises_value_error(call):
    with pytest.raises(ValueError):
        call()
