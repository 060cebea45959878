"""Geometry of the conformal camera (paper §3-§4).

Eye frame: x2 is the optical axis, x3 points right, x1 up; the image plane is x2 = 1 and
a point projects to z = (x3 + i x1) / x2 (eq. ``proj``). The group SL(2, C) acts on the
image plane by the paper's linear-fractional action (eq. ``lft1``)

    g . z = (d z + c) / (b z + a),   g = [[a, b], [c, d]],

which is a homomorphism: (g1 @ g2) . z = g1 . (g2 . z). Images transform as
f(g^{-1} . z) (eq. ``IPT``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import checks
from .maps import POLE_TOL, homography, is_pole, mobius

__all__ = [
    "PERM_FLAT",
    "project",
    "lift_to_sphere",
    "act",
    "transform_image",
    "k_matrix",
    "h_matrix",
    "compose",
    "inverse",
    "check_sl2",
    "check_rotation",
    "euler_rotation",
    "su2_from_rotation",
    "mobius_from_points",
    "apply_homography",
    "rotation_from_su2",
    "rotation_homography",
    "SPHERE_CENTRE",
]

SPHERE_CENTRE = np.array([0.0, 1.0, 0.0])
SPHERE_CENTRE.setflags(write=False)
"""Centre (x1, x2, x3) of the unit sphere S^2_(0,1,0) on which j is the stereographic projection (read-only)."""

_EYE3 = np.eye(3)


def _as_points(x: ArrayLike, name: str) -> NDArray[np.float64]:
    p = checks.array(name, x, kinds="biuf")
    if p.shape[-1:] != (3,):
        raise ValueError(f"{name} must have shape (..., 3) as (x1, x2, x3); got {p.shape}")
    return p.astype(float)


def _as_z(z: ArrayLike, name: str = "z") -> NDArray[np.complex128]:
    """Finite image-plane points as complex (the point at infinity is not a valid input)."""
    return checks.array(name, z, kinds="biufc").astype(complex)


def _finite_result(w: NDArray, what: str) -> NDArray:
    """``w`` unless some value overflowed the floating-point range (then ``ValueError``)."""
    if not np.all(np.isfinite(w)):
        raise ValueError(
            f"{what} sends some points beyond the floating-point range (|z| > 1e308); use smaller coordinates"
        )
    return w


def project(points: ArrayLike) -> NDArray[np.complex128]:
    """The conformal camera's projection j(x1, x2, x3) = (x3 + i x1) / x2 (eq. ``proj``).

    ``points`` has shape (..., 3) in (x1, x2, x3) order. Points with x2 = 0 project to
    infinity and raise ``ValueError``.
    """
    p = _as_points(points, "points")
    x2 = p[..., 1]
    if np.any(np.abs(x2) < POLE_TOL):
        raise ValueError("points with x2 = 0 project to infinity (they lie in the plane of the nodal point)")
    with np.errstate(over="ignore"):
        return _finite_result((p[..., 2] + 1j * p[..., 0]) / x2, "the projection")


def lift_to_sphere(z: ArrayLike) -> NDArray[np.float64]:
    """Inverse of j restricted to the unit sphere centred at (0, 1, 0): (j|S^2)^{-1}(z).

    The ray t (Im z, 1, Re z) meets the sphere (which passes through the nodal point 0)
    again at t = 2 / (1 + |z|^2). Returns points (..., 3) as (x1, x2, x3).
    """
    zz = _as_z(z)
    with np.errstate(over="ignore"):  # |z|^2 = inf gives t = 0: the nodal point, correctly
        t = 2.0 / (1.0 + np.abs(zz) ** 2)
        return np.stack([t * zz.imag, t, t * zz.real], axis=-1)


#: Rounding allowance of the determinant test, relative to |a d| + |b c| (the size of the two
#: products whose difference is the determinant): a product of k unimodular matrices (``compose``)
#: keeps its determinant to about k * 2.2e-16 of that size, so this admits products of ~10^5 factors.
_DET_RELATIVE_TOL = 1e-10


def check_sl2(g: ArrayLike, name: str = "g", tol: float = 1e-9) -> NDArray[np.complex128]:
    """Validate a finite 2x2 complex matrix of determinant 1 (an element of SL(2, C)).

    The determinant must be 1 within ``tol`` (in (0, 0.01]) plus a rounding allowance of 1e-10
    times |a d| + |b c|, so that matrices with large entries (and products of many matrices,
    see ``compose``) whose determinant is 1 up to floating-point rounding are accepted.
    """
    if not isinstance(name, str):
        raise checks.InputTypeError(f"name must be a string; got {type(name).__name__}")
    tol = checks.real("tol", tol, 0.0, 0.01, lo_open=True)
    m = checks.array(name, g, kinds="biufc", shape=(2, 2)).astype(complex)
    ad, bc = m[0, 0] * m[1, 1], m[0, 1] * m[1, 0]
    det = ad - bc
    if not abs(det - 1.0) <= tol + _DET_RELATIVE_TOL * (abs(ad) + abs(bc)):
        raise ValueError(f"{name} is not unimodular (det = {det:.6g}, must be 1); divide it by sqrt(det) to normalise")
    return m


def act(g: ArrayLike, z: ArrayLike) -> NDArray[np.complex128]:
    """The paper's action of SL(2, C) on the image plane, g . z = (d z + c)/(b z + a) (eq. ``lft1``).

    Vectorised over ``z``. Raises ``ValueError`` for non-unimodular ``g``, NaN or infinite
    ``z``, and for points sent to infinity (b z + a = 0).
    """
    w, pole = mobius(check_sl2(g), _as_z(z))
    if np.any(pole):
        raise ValueError("some points are sent to infinity by g (b z + a = 0, i.e. z = -a/b)")
    return _finite_result(w, "g")


def transform_image(f, g: ArrayLike):
    """The image projective transformation f -> f(g^{-1} . z) (eq. ``IPT``), as a new function of z."""
    checks.callable_("f", f)
    g_inv = inverse(g)

    def transformed(z: ArrayLike):
        return f(act(g_inv, z))

    return transformed


def compose(*gs: ArrayLike) -> NDArray[np.complex128]:
    """Composition in PSL(2, C): ``compose(g1, g2)`` acts as g1 . (g2 . z).

    The product's determinant is 1 up to rounding relative to the size of its entries, which
    ``check_sl2`` (and so ``act``) accepts; a product that overflows raises ``ValueError``.
    """
    out = np.eye(2, dtype=complex)
    with np.errstate(over="ignore", invalid="ignore"):
        for i, g in enumerate(gs):
            out = out @ check_sl2(g, f"g{i + 1}")
    if not np.all(np.isfinite(out)):
        raise ValueError(
            "the product of the matrices overflows the floating-point range; compose fewer or smaller matrices"
        )
    return out


def inverse(g: ArrayLike) -> NDArray[np.complex128]:
    """Inverse in SL(2, C): [[d, -b], [-c, a]] (used in eq. ``IPT``)."""
    a, b, c, d = check_sl2(g).ravel()
    return np.array([[d, -b], [-c, a]], dtype=complex)


def k_matrix(psi: float, phi: float, psi2: float) -> NDArray[np.complex128]:
    """The SU(2) element of eq. ``k`` for Euler angles (psi, phi, psi').

    Under the action of eq. ``lft1`` it equals j o R o (j|S^2)^{-1}, with
    R = ``euler_rotation(psi, phi, psi2)`` a rotation of S^2 about its centre (0, 1, 0).
    (The printed linear-fractional form, eq. ``lfk``, is not used: it disagrees with eq. ``k``.)
    """
    psi, phi, psi2 = (checks.real(n, v) for n, v in (("psi", psi), ("phi", phi), ("psi2", psi2)))
    cp, sp = np.cos(phi / 2), np.sin(phi / 2)
    return np.array(
        [
            [np.exp(1j * (psi + psi2) / 2) * cp, 1j * np.exp(1j * (psi - psi2) / 2) * sp],
            [1j * np.exp(-1j * (psi - psi2) / 2) * sp, np.exp(-1j * (psi + psi2) / 2) * cp],
        ]
    )


def h_matrix(b1: float, b2: float, b3: float) -> NDArray[np.complex128]:
    """The SL(2, C) element of eq. ``h`` for the translation b = (b1, b2, b3), b2 != -1.

    Under eq. ``lft1`` it equals j o T_b o (j|_{x2=1})^{-1}: z -> (z + b3 + i b1) / (1 + b2).
    For 1 + b2 < 0 the square root is imaginary (the paper's epsilon A N-bar coset).
    """
    b1, b2, b3 = (checks.real(n, v) for n, v in (("b1", b1), ("b2", b2), ("b3", b3)))
    if abs(1.0 + b2) < POLE_TOL:
        raise ValueError("b2 = -1 translates the image plane into the nodal plane (x2 = 0); not allowed")
    s = np.sqrt(complex(1.0 + b2))
    return np.array([[s, 0.0], [(b3 + 1j * b1) / s, 1.0 / s]], dtype=complex)


def _axis_rotation(axis: int, angle: float) -> NDArray[np.float64]:
    """Right-handed rotation by ``angle`` about coordinate axis ``axis`` (0: x1, 1: x2, 2: x3)."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    r = np.eye(3)
    r[i, i] = c
    r[j, j] = c
    r[i, j] = -s
    r[j, i] = s
    return r


def euler_rotation(psi: float, phi: float, psi2: float) -> NDArray[np.float64]:
    """The rotation R(psi, phi, psi') of S^2 about its centre that eq. ``k`` represents.

    Coordinates (x1, x2, x3). Rotation psi about the x2 axis, then phi about the y3 axis
    (parallel to x3 through (0, 1, 0)), then psi' about the rotated x2 axis; with the paper's
    action (eq. ``lft1``) the senses are clockwise (negative) when viewed along the axis, so
    R = Rot_x2(-psi) Rot_x3(-phi) Rot_x2(-psi') (intrinsic composition).
    """
    psi, phi, psi2 = (checks.real(n, v) for n, v in (("psi", psi), ("phi", phi), ("psi2", psi2)))
    return _axis_rotation(1, -psi) @ _axis_rotation(2, -phi) @ _axis_rotation(1, -psi2)


def _apply_sphere_rotation(R: NDArray[np.float64], z: NDArray[np.complex128]) -> NDArray[np.complex128]:
    p = lift_to_sphere(z) - SPHERE_CENTRE
    q = p @ R.T + SPHERE_CENTRE
    return project(q)


def mobius_from_points(z: ArrayLike, w: ArrayLike) -> NDArray[np.complex128]:
    """The unique g in SL(2, C) (up to sign) with g . z_i = w_i for three distinct finite points.

    Returned in the paper's convention (eq. ``lft1``), so ``act(g, z) == w``.
    """
    zz, ww = _as_z(z, "z"), _as_z(w, "w")
    if zz.shape != (3,) or ww.shape != (3,):
        raise ValueError("mobius_from_points needs exactly three points z and three images w")
    for name, p in (("z", zz), ("w", ww)):
        if min(abs(p[0] - p[1]), abs(p[1] - p[2]), abs(p[0] - p[2])) < 1e-12:
            raise ValueError(f"the three points {name} must be distinct")

    def to_standard(p):  # standard matrix sending p0 -> 0, p1 -> 1, p2 -> infinity
        return np.array([[p[1] - p[2], -p[0] * (p[1] - p[2])], [p[1] - p[0], -p[2] * (p[1] - p[0])]])

    m = np.linalg.solve(to_standard(ww), to_standard(zz))  # standard w = (m00 z + m01)/(m10 z + m11)
    m = m / np.sqrt(np.linalg.det(m))
    return np.array([[m[1, 1], m[1, 0]], [m[0, 1], m[0, 0]]])


def check_rotation(R: ArrayLike, name: str = "R") -> NDArray[np.float64]:
    """Validate a proper 3x3 rotation matrix (finite, orthogonal to 1e-6, det +1)."""
    if not isinstance(name, str):
        raise checks.InputTypeError(f"name must be a string; got {type(name).__name__}")
    r = checks.array(name, R, kinds="biuf", shape=(3, 3)).astype(float)
    (a, b, c), (d, e, f), (g, h, i) = r.tolist()
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    if det < 0 or np.abs(r @ r.T - _EYE3).max() > 1e-6:
        raise ValueError(f"{name} must be a proper rotation matrix (orthogonal, det +1)")
    return r


def su2_from_rotation(R: ArrayLike) -> NDArray[np.complex128]:
    """The element k of SU(2) (up to sign) with k . z = j(R (j|S^2)^{-1}(z)), R rotating S^2 about (0,1,0)."""
    r = check_rotation(R)
    z = np.array([0.0, 1.0, 1j, -1.0, -1j])
    q = (lift_to_sphere(z) - SPHERE_CENTRE) @ r.T + SPHERE_CENTRE
    finite = np.abs(q[:, 1]) > 1e-6  # images away from the nodal point (z = infinity)
    idx = np.flatnonzero(finite)[:3]
    return mobius_from_points(z[idx], project(q[idx]))


def rotation_from_su2(k: ArrayLike) -> NDArray[np.float64]:
    """The rotation of S^2 about (0, 1, 0) that an SU(2) element induces (inverse of ``su2_from_rotation``)."""
    kk = check_sl2(k, "k")
    if not np.allclose(kk @ kk.conj().T, np.eye(2), atol=1e-9):
        raise ValueError("k must be unitary (an element of SU(2))")
    # Images of three points determine the rotation: sphere points for z = 0, 1, i.
    z = np.array([0.0, 1.0, 1j, -1.0])
    p = lift_to_sphere(z) - SPHERE_CENTRE
    q = lift_to_sphere(act(kk, z)) - SPHERE_CENTRE
    u, _, vt = np.linalg.svd(q.T @ p)
    d = np.sign(np.linalg.det(u @ vt))
    return u @ np.diag([1.0, 1.0, d]) @ vt


def rotation_homography(R: ArrayLike) -> NDArray[np.float64]:
    """Homography of a pinhole eye rotating about its nodal point, in homogeneous (x3, x1, x2).

    ``R`` maps a direction in the *new* eye frame to the *old* eye frame (columns: the new
    axes x1, x2, x3 in old coordinates). Then a point seen at z_new is seen at
    z_old = H . z_new with H acting on (Re z, Im z, 1). Use ``apply_homography``.
    """
    return _rotation_homography(check_rotation(R))


_PERM = [2, 0, 1]  # (x3, x1, x2) <- (x1, x2, x3)
#: P R P^T as a gather of R's row-major entries: H.ravel() = R.ravel()[PERM_FLAT] (a copy, exact).
PERM_FLAT = np.array([3 * i + j for i in _PERM for j in _PERM])


def _rotation_homography(r: NDArray[np.float64]) -> NDArray[np.float64]:
    """``rotation_homography`` of a rotation already validated (``check_rotation``): P R P^T."""
    return r[_PERM][:, _PERM]


def apply_homography(H: ArrayLike, z: ArrayLike) -> NDArray[np.complex128]:
    """Apply a 3x3 homography acting on (Re z, Im z, 1) to image-plane points ``z``.

    ``H`` must be a finite, real, invertible 3x3 matrix; points sent to infinity (homogeneous
    weight 0) raise ``ValueError``.
    """
    out, w3 = homography(_check_homography(H), _as_z(z))
    with np.errstate(over="ignore"):
        if np.any(is_pole(w3 * w3)):
            raise ValueError("some points are sent to infinity by the homography (they leave the eye's front)")
    return _finite_result(out, "the homography")


def _check_homography(H: ArrayLike, name: str = "H") -> NDArray[np.float64]:
    """Validate a finite, real, invertible 3x3 homography (acting on (Re z, Im z, 1))."""
    h = checks.array(name, H, kinds="biuf", shape=(3, 3)).astype(float)
    if not np.linalg.cond(h) < 1e12:  # (cond is inf for a zero matrix)
        raise ValueError(f"{name} must be invertible (a singular homography collapses the plane onto a line)")
    return h
