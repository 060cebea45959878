"""The efference copy's point maps, written once, with one pole tolerance and one pole rule.

Two maps send an image-plane point z = x + i y to another:

* the Moebius map of eq. ``lft1``, g . z = (d z + c) / (b z + a) for g = [[a, b], [c, d]];
* the homography of a pinhole eye, H acting on (x, y, 1): z -> (H_0 . (x, y, 1) + i H_1 . (x, y, 1)) / w3
  with the homogeneous weight w3 = H_2 . (x, y, 1) (``geometry.rotation_homography``).

**The pole rule.** A point is a *pole* of a map when the map's denominator D (b z + a, or w3) has
|D| < ``POLE_TOL``, tested without a square root as |D|^2 < ``POLE_TOL_SQ`` (:func:`is_pole`). For an
eye's homography the points behind the old eye (w3 < 0) are not seen either, so a point is unseen when
w3 < ``POLE_TOL`` (:func:`behind`). A caller that must map every point raises ``ValueError`` at a pole
(``geometry.act``, ``geometry.apply_homography``, for which w3 < 0 is a valid point); the remapping maps
(``remap.MobiusMap``, ``remap.ProjectiveMap``) give NaN there; the compiled kernels
(``kernels.map_points``) and the torch series (``conformal.torch_plan``) mark the point invalid.

**Two arithmetic forms of each map.** :func:`mobius` and :func:`homography` are the complex form of the
numpy callers (numpy divides complex numbers by Smith's method). :func:`mobius_point` and
:func:`homography_point` are the real form on a row ``p`` of map parameters (the layout of
``KIND_MOBIUS`` and ``KIND_PROJECTIVE``), built from :func:`mobius_parts`, :func:`homography_plane` and
:func:`homography_weight`: plain, branch-free Python functions that work on numpy arrays and torch
tensors (vectorised by broadcasting) and that ``conformal.kernels`` compiles inline with numba, as
``models._plan_kernels`` compiles its scalar formulas. The two forms round differently, so each caller
keeps its results to the last bit (``tests/test_maps.py``). The kernels divide only where a point is
seen (numba raises on a division by zero); the real form divides everywhere and masks.

numba's disk cache of ``conformal.kernels`` does not notice an edit of this file: after one, delete the
cache (``__pycache__/*.nbi``, ``*.nbc`` beside ``kernels.py``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "POLE_TOL",
    "POLE_TOL_SQ",
    "KIND_PROJECTIVE",
    "KIND_MOBIUS",
    "is_pole",
    "behind",
    "mobius",
    "homography",
    "mobius_parts",
    "mobius_point",
    "homography_weight",
    "homography_plane",
    "homography_point",
]

#: The one pole tolerance: a denominator of modulus below it is a pole (see the module docstring).
POLE_TOL = 1e-12
#: ``POLE_TOL`` squared, for the test on |D|^2.
POLE_TOL_SQ = POLE_TOL * POLE_TOL

KIND_PROJECTIVE = 0  # params: the 3x3 matrix H row-major, acting on (Re z, Im z, 1)
KIND_MOBIUS = 1  # params: a, b, c, d (re, im) of g . z = (d z + c) / (b z + a), then 0


def is_pole(den_sq):
    """The pole rule on a denominator's squared modulus |D|^2: |D| < ``POLE_TOL``."""
    return den_sq < POLE_TOL_SQ


def behind(w3):
    """Whether an eye's homography image of weight w3 is unseen: behind the eye or a pole (w3 < ``POLE_TOL``)."""
    return w3 < POLE_TOL


def mobius(g: NDArray[np.complex128], z: NDArray[np.complex128]) -> tuple[NDArray[np.complex128], NDArray[np.bool_]]:
    """(d z + c) / (b z + a) for a checked complex 2x2 g (eq. ``lft1``), complex form, and the poles' mask."""
    a, b, c, d = g.ravel()
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        den = b * z + a
        w = (d * z + c) / den
        return w, is_pole(den.real * den.real + den.imag * den.imag)


def homography(h: NDArray[np.float64], z: NDArray[np.complex128]) -> tuple[NDArray[np.complex128], NDArray[np.float64]]:
    """A checked real 3x3 homography applied to z as (x, y, 1), complex form, and its weight w3."""
    x, y = z.real, z.imag
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        w3 = h[2, 0] * x + h[2, 1] * y + h[2, 2]
        return ((h[0, 0] * x + h[0, 1] * y + h[0, 2]) + 1j * (h[1, 0] * x + h[1, 1] * y + h[1, 2])) / w3, w3


def mobius_parts(p, x, y):
    """Numerator d z + c and denominator b z + a of the Moebius map at z = x + i y, as (nr, ni, dr, di);
    p = (Re a, Im a, Re b, Im b, Re c, Im c, Re d, Im d, 0)."""
    nr = p[6] * x - p[7] * y + p[4]
    ni = p[6] * y + p[7] * x + p[5]
    dr = p[2] * x - p[3] * y + p[0]
    di = p[2] * y + p[3] * x + p[1]
    return nr, ni, dr, di


def mobius_point(p, x, y):
    """The Moebius map, real form, on arrays or tensors: (Re w, Im w, pole) with pole = :func:`is_pole`."""
    nr, ni, dr, di = mobius_parts(p, x, y)
    den = dr * dr + di * di
    return (nr * dr + ni * di) / den, (ni * dr - nr * di) / den, is_pole(den)


def homography_weight(p, x, y):
    """The weight w3 = H_2 . (x, y, 1) of the homography p (H row-major) at z = x + i y."""
    return p[6] * x + p[7] * y + p[8]


def homography_plane(p, x, y):
    """H_0 . (x, y, 1) and H_1 . (x, y, 1): the image's coordinates times w3."""
    return p[0] * x + p[1] * y + p[2], p[3] * x + p[4] * y + p[5]


def homography_point(p, x, y):
    """The eye's homography, real form, on arrays or tensors: (Re w, Im w, unseen) with unseen = :func:`behind`."""
    w3 = homography_weight(p, x, y)
    nu, nv = homography_plane(p, x, y)
    return nu / w3, nv / w3, behind(w3)
