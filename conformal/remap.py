"""Efference-copy remapping: predicting the post-saccadic retina from pre-saccadic coefficients.

An eye rotation is given as R, the new eye axes in old eye coordinates (x1, x2, x3): a
direction v seen in the new frame is R v in the old one. Three point maps send a
post-saccadic image-plane point z to where the same content lay before the saccade:

* ``homography_map(R)``: the exact pinhole map of a rotation about the nodal point
  (distant-scene approximation: no parallax from the nodal point's own motion).
* ``mobius_map(R)``: the conformal camera's k-transform (eq. ``k``): S^2 rotated about its
  centre (0, 1, 0) about R's axis by twice R's angle (the inscribed-angle relation), so the
  fixation point moves exactly as under R; other points move conformally, not projectively.
* ``target_shift_map(z_target, shift, delta)``: the paper's §6.5 remapping: translation
  into the target-centred frame and a log-radius shift by ``shift`` rings around the target,
  w = z_target + e^{shift delta} z (shift > 0 compresses space towards the target).

``predict`` evaluates the pre-saccadic DPFT series (eq. ``dppcc'``) at w(z) for the
peripheral grid and the foveal lattice; points that fall in the old fovea take the foveal
samples (bilinear on the lattice), points beyond r_b are reported in the mask.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .dpft import OffGridEvaluator
from .fovea import fovea_image
from .geometry import _POLE_TOL, check_rotation, rotation_homography
from .grid import RetinaGrid
from .kernels import KIND_MOBIUS, KIND_PROJECTIVE
from .sampling import RetinaSamples

__all__ = ["ProjectiveMap", "MobiusMap", "homography_map", "mobius_map", "mobius_for_rotation", "target_shift_map", "predict", "predict_many", "rotation_matrix"]

PointMap = Callable[[NDArray[np.complex128]], NDArray[np.complex128]]


def rotation_matrix(axis: ArrayLike, angle: float) -> NDArray[np.float64]:
    """Right-handed rotation by ``angle`` about unit ``axis`` (Rodrigues), coordinates (x1, x2, x3)."""
    n = np.asarray(axis, dtype=float)
    norm = np.linalg.norm(n)
    if not np.isfinite(angle) or norm == 0 or not np.isfinite(norm):
        raise ValueError("axis must be a finite non-zero vector and angle finite")
    n = n / norm
    K = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def _fixed_matrix(x: ArrayLike, shape: tuple[int, int], dtype: type, name: str) -> NDArray:
    """A read-only copy of a finite matrix of ``shape`` (a point map's parameters)."""
    m = np.array(x, dtype=dtype)
    if m.shape != shape or not np.all(np.isfinite(m)):
        raise ValueError(f"{name} must be a finite {shape[0]}x{shape[1]} matrix; got shape {m.shape}")
    m.setflags(write=False)
    return m


class ProjectiveMap:
    """z -> H . z for a real 3x3 homography H acting on (Re z, Im z, 1) (see ``apply_homography``).

    A point whose homogeneous weight is <= 0 maps to NaN: for an eye rotation
    (``homography_map``) it is a direction behind the old eye, which the old image never saw.
    ``kind`` and ``params`` describe the map to the compiled ``RemapPlan``.
    """

    kind = KIND_PROJECTIVE

    def __init__(self, H: ArrayLike) -> None:
        self.matrix = _fixed_matrix(H, (3, 3), float, "H")
        self.params = self.matrix.ravel().copy()

    def __call__(self, z: ArrayLike) -> NDArray[np.complex128]:
        h = self.matrix
        zz = np.asarray(z, dtype=complex)
        x, y = zz.real, zz.imag
        w = h[2, 0] * x + h[2, 1] * y + h[2, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            out = ((h[0, 0] * x + h[0, 1] * y + h[0, 2]) + 1j * (h[1, 0] * x + h[1, 1] * y + h[1, 2])) / w
        return np.where(w > _POLE_TOL, out, np.nan + 0j)


class MobiusMap:
    """z -> g . z = (d z + c) / (b z + a) for g = [[a, b], [c, d]] (eq. ``lft1``, as ``act``).

    Poles (b z + a = 0) map to NaN. ``kind`` and ``params`` describe the map to ``RemapPlan``.
    """

    kind = KIND_MOBIUS

    def __init__(self, g: ArrayLike) -> None:
        self.matrix = _fixed_matrix(g, (2, 2), complex, "g")
        a, b, c, d = self.matrix.ravel()
        self.params = np.array([a.real, a.imag, b.real, b.imag, c.real, c.imag, d.real, d.imag, 0.0])

    def __call__(self, z: ArrayLike) -> NDArray[np.complex128]:
        a, b, c, d = self.matrix.ravel()
        zz = np.asarray(z, dtype=complex)
        den = b * zz + a
        with np.errstate(divide="ignore", invalid="ignore"):
            out = (d * zz + c) / den
        return np.where(np.abs(den) >= _POLE_TOL, out, np.nan + 0j)


def homography_map(R: ArrayLike) -> ProjectiveMap:
    """z_new -> z_old for a pinhole eye rotating about its nodal point (see module docstring)."""
    return ProjectiveMap(rotation_homography(R))


def mobius_for_rotation(R: ArrayLike) -> NDArray[np.complex128]:
    """The SU(2) element of the sphere rotation that corresponds to the eye rotation R.

    The sphere S^2_(0,1,0) turns about R's axis n by twice R's angle theta, so its SU(2) element
    has half-angle theta (eq. ``k`` up to the choice of axes): with s = sin(theta) n read off R's
    antisymmetric part and cos(theta) = (tr R - 1)/2, k = [[conj(a), -conj(b)], [b, a]] with
    a = cos(theta) + i s_2, b = s_1 - i s_3 (x1, x2, x3 components; j projects from the sphere's
    point (0, 0, 0), hence the axes' order). Tested against the 3-D construction
    ``su2_from_rotation(rotation_matrix(n, 2 theta))``. An eye turned by pi gives the identity.
    """
    r = check_rotation(R)
    cos_t = (r[0, 0] + r[1, 1] + r[2, 2] - 1.0) / 2.0
    s1, s2, s3 = (r[2, 1] - r[1, 2]) / 2.0, (r[0, 2] - r[2, 0]) / 2.0, (r[1, 0] - r[0, 1]) / 2.0
    a, b = complex(cos_t, s2), complex(s1, -s3)
    norm = math.sqrt(abs(a) ** 2 + abs(b) ** 2)  # 1 up to R's rounding
    a, b = a / norm, b / norm
    return np.array([[a.conjugate(), -b.conjugate()], [b, a]])


def mobius_map(R: ArrayLike) -> MobiusMap:
    """z_new -> z_old under the conformal camera's k-transform for the eye rotation R."""
    return MobiusMap(mobius_for_rotation(R))


def target_shift_map(z_target: complex, shift: float, delta: float) -> MobiusMap:
    """z_new -> z_old = z_target + e^{shift delta} z: §6.5's remap into the target-centred frame.

    An affine map, so a ``MobiusMap`` (normalised to determinant 1)."""
    zt = complex(z_target)
    if not (math.isfinite(zt.real) and math.isfinite(zt.imag) and math.isfinite(shift) and math.isfinite(delta)):
        raise ValueError("z_target, shift and delta must be finite")
    root = math.exp(shift * delta / 2)  # sqrt of the scale
    return MobiusMap(np.array([[1 / root, 0], [zt / root, root]]))


def _fovea_lookup(fovea: NDArray, grid: RetinaGrid, w: NDArray[np.complex128]) -> NDArray:
    """Bilinear interpolation of the foveal lattice picture at points w (inside the fovea)."""
    img = fovea_image(fovea, grid)
    size = img.shape[0]
    half = size / 2
    col = w.real / grid.fovea_spacing + half - 0.5
    row = half - 0.5 - w.imag / grid.fovea_spacing
    c0 = np.clip(np.floor(col).astype(int), 0, size - 2)
    r0 = np.clip(np.floor(row).astype(int), 0, size - 2)
    fc = np.clip(col - c0, 0, 1)
    fr = np.clip(row - r0, 0, 1)
    ex = (slice(None),) + (None,) * (img.ndim - 2)
    return (
        img[r0, c0] * ((1 - fr) * (1 - fc))[ex]
        + img[r0, c0 + 1] * ((1 - fr) * fc)[ex]
        + img[r0 + 1, c0] * (fr * (1 - fc))[ex]
        + img[r0 + 1, c0 + 1] * (fr * fc)[ex]
    )


def predict(
    coeffs: ArrayLike, fovea: ArrayLike, grid: RetinaGrid, point_map: PointMap, *, on: RetinaGrid | None = None
) -> RetinaSamples:
    """Predicted samples of the image f(w(z)) on the whole retina from pre-saccadic data only.

    ``coeffs``: the pre-saccadic DPFT (M, N[, C]) on ``grid``; ``fovea``: the pre-saccadic foveal
    samples. The result is sampled at the points z of ``on`` (default: ``grid`` itself; another
    grid, e.g. a finer one, for read-outs). The peripheral part comes from the DPFT series
    (eq. ``dppcc'``); points landing in the old fovea from the foveal samples. ``mask`` /
    ``fovea_mask`` flag points whose source lies beyond r_b or behind the eye (unknown).
    """
    return predict_many(coeffs, fovea, grid, [point_map], on=on)[0]


def _map_points(point_map: PointMap, z: NDArray[np.complex128]) -> NDArray[np.complex128]:
    """w(z), with NaN where the map sends a point to infinity (behind the eye)."""
    with np.errstate(all="ignore"):
        try:
            return np.asarray(point_map(z), dtype=complex)
        except ValueError:
            w = np.full(z.shape, np.nan + 0j)
            for i, zi in enumerate(z):
                try:
                    w[i] = complex(np.asarray(point_map(np.array([zi])))[0])
                except ValueError:
                    pass
            return w


def predict_many(
    coeffs: ArrayLike,
    fovea: ArrayLike,
    grid: RetinaGrid,
    point_maps: list[PointMap],
    *,
    on: RetinaGrid | None = None,
    dtype: type = np.float64,
) -> list[RetinaSamples]:
    """``predict`` for several point maps at once, sharing one evaluation of the series.

    ``dtype=np.float32`` evaluates the series in single precision (~1e-6 relative; a few times
    faster, see ``OffGridEvaluator``)."""
    F = np.asarray(coeffs)
    fov = np.asarray(fovea, dtype=float)
    out_grid = grid if on is None else on
    z = np.concatenate([out_grid.fovea_points, out_grid.points.ravel()])
    n_pts, n_f = len(z), out_grid.n_fovea
    w = np.concatenate([_map_points(pm, z) for pm in point_maps])
    finite = np.isfinite(w)
    r = np.where(finite, np.abs(w), np.inf)
    in_fovea = finite & (r < grid.r0)
    in_periph = finite & (r >= grid.r0) & (r < grid.ring_edges[-1])
    chans = F.shape[2:]
    out = np.zeros((len(w),) + chans)
    if np.any(in_periph):
        out[in_periph] = OffGridEvaluator(grid, w[in_periph], dtype=dtype)(F)
    if np.any(in_fovea):
        out[in_fovea] = _fovea_lookup(fov, grid, w[in_fovea])
    valid = in_fovea | in_periph
    results = []
    for i in range(len(point_maps)):
        sl = slice(i * n_pts, (i + 1) * n_pts)
        o, v = out[sl], valid[sl]
        results.append(
            RetinaSamples(
                fovea=o[:n_f],
                periphery=o[n_f:].reshape((out_grid.M, out_grid.N) + chans),
                mask=v[n_f:].reshape(out_grid.M, out_grid.N),
                fovea_mask=v[:n_f],
            )
        )
    return results
