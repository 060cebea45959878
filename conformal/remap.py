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
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, DTypeLike, NDArray

from . import checks
from .dpft import OffGridEvaluator, _check_float_dtype, _check_grid, _check_samples
from .fovea import fovea_image
from .geometry import PERM_FLAT, _check_homography, check_rotation, rotation_homography
from .grid import RetinaGrid
from .maps import KIND_MOBIUS, KIND_PROJECTIVE, behind, homography, mobius
from .sampling import RetinaSamples

__all__ = [
    "ProjectiveMap",
    "MobiusMap",
    "homography_map",
    "mobius_map",
    "mobius_for_rotation",
    "target_shift_map",
    "predict",
    "predict_many",
    "rotation_matrix",
    "mobius_params",
    "point_map_params",
    "target_shift_matrix",
]

PointMap = Callable[[NDArray[np.complex128]], NDArray[np.complex128]]


def rotation_matrix(axis: ArrayLike, angle: float) -> NDArray[np.float64]:
    """Right-handed rotation by ``angle`` (radians) about ``axis`` (a finite non-zero 3-vector,
    normalised here; Rodrigues), coordinates (x1, x2, x3)."""
    n = checks.array("axis", axis, kinds="biuf", shape=(3,)).astype(float)
    angle = checks.real("angle", angle)
    scale = np.abs(n).max()
    if scale == 0:
        raise ValueError("axis must be a non-zero vector")
    n = n / scale
    n = n / np.linalg.norm(n)
    K = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def _fixed(m: NDArray) -> NDArray:
    """A read-only copy (a point map's parameters)."""
    m = m.copy()
    m.setflags(write=False)
    return m


def _map_input(z: ArrayLike) -> NDArray[np.complex128]:
    return checks.array("z", z, kinds="biufc").astype(complex)


class ProjectiveMap:
    """z -> H . z for a real 3x3 homography H acting on (Re z, Im z, 1) (see ``apply_homography``).

    A point whose homogeneous weight is below ``conformal.maps.POLE_TOL`` maps to NaN (``maps.behind``):
    for an eye rotation (``homography_map``) it is a direction behind the old eye, which the old image
    never saw, or a pole.
    ``kind`` and ``params`` describe the map to the compiled ``RemapPlan``.
    """

    kind = KIND_PROJECTIVE

    def __init__(self, H: ArrayLike) -> None:
        self.matrix = _fixed(_check_homography(H, "H (a finite real invertible 3x3 matrix)"))
        self.params = self.matrix.ravel().copy()

    def __call__(self, z: ArrayLike) -> NDArray[np.complex128]:
        out, w3 = homography(self.matrix, _map_input(z))
        return np.where(behind(w3), np.nan + 0j, out)


def mobius_params(g: NDArray[np.complex128]) -> NDArray[np.float64]:
    """``MobiusMap``'s ``params`` (for the compiled kernels) of complex 2x2 matrices g (..., 2, 2):
    (..., 9) = (a, b, c, d) as (real, imag) pairs and a 0."""
    g = np.asarray(g)
    out = np.zeros(g.shape[:-2] + (9,))
    flat = g.reshape(g.shape[:-2] + (4,))
    out[..., 0:8:2], out[..., 1:8:2] = flat.real, flat.imag
    return out


class MobiusMap:
    """z -> g . z = (d z + c) / (b z + a) for g = [[a, b], [c, d]] (eq. ``lft1``, as ``act``).

    Poles (|b z + a| < ``conformal.maps.POLE_TOL``, ``maps.is_pole``) map to NaN. ``kind`` and ``params``
    describe the map to ``RemapPlan``.
    """

    kind = KIND_MOBIUS

    def __init__(self, g: ArrayLike) -> None:
        m = checks.array("g (a finite invertible 2x2 matrix)", g, kinds="biufc", shape=(2, 2)).astype(complex)
        ad, bc = m[0, 0] * m[1, 1], m[0, 1] * m[1, 0]
        if not abs(ad - bc) > 1e-12 * (abs(ad) + abs(bc)):
            raise ValueError("g must be invertible (a d - b c != 0): a singular g sends every point to one point")
        self.matrix = _fixed(m)
        self.params = mobius_params(self.matrix)

    def __call__(self, z: ArrayLike) -> NDArray[np.complex128]:
        out, pole = mobius(self.matrix, _map_input(z))
        return np.where(pole, np.nan + 0j, out)


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
    return _su2_of_rotation(check_rotation(R))


def _su2_of_rotation(r: NDArray[np.float64]) -> NDArray[np.complex128]:
    """``mobius_for_rotation`` of rotations already validated (``check_rotation``), (..., 3, 3) -> (..., 2, 2)."""
    cos_t = (r[..., 0, 0] + r[..., 1, 1] + r[..., 2, 2] - 1.0) / 2.0
    s1, s2, s3 = (
        (r[..., 2, 1] - r[..., 1, 2]) / 2.0,
        (r[..., 0, 2] - r[..., 2, 0]) / 2.0,
        (r[..., 1, 0] - r[..., 0, 1]) / 2.0,
    )
    norm = np.sqrt(np.hypot(cos_t, s2) ** 2 + np.hypot(s1, s3) ** 2)  # 1 up to R's rounding
    k = np.empty(
        np.shape(cos_t) + (2, 2), complex
    )  # [[conj(a), -conj(b)], [b, a]], a = (cos_t + i s2) / norm, b = (s1 - i s3) / norm
    ar, ai, br, bi = cos_t / norm, s2 / norm, s1 / norm, -s3 / norm
    k[..., 0, 0].real, k[..., 0, 0].imag, k[..., 0, 1].real, k[..., 0, 1].imag = ar, -ai, -br, bi
    k[..., 1, 0].real, k[..., 1, 0].imag, k[..., 1, 1].real, k[..., 1, 1].imag = br, bi, ar, ai
    return k


def point_map_params(
    names,
    rotations: NDArray[np.float64],
    shift: float,
    delta: float,
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """``RemapPlan``'s description -- kinds (K,) and params (..., K, 9) -- of the point maps ``names``
    (``"homography"``: :func:`homography_map`; ``"mobius"``: :func:`mobius_map`; ``"shift"``:
    :func:`target_shift_map` to the new optical axis, R's second column, on the old retina plane) of
    rotations (..., 3, 3) already validated (proper; with ``shift``, the new optical axis in front of
    the old eye), without building the map objects: the numbers the maps' ``params`` hold."""
    r = np.asarray(rotations, float)
    lead = r.shape[:-2]
    kinds = np.array([KIND_PROJECTIVE if m == "homography" else KIND_MOBIUS for m in names], np.int64)
    params = np.empty(lead + (len(names), 9))
    for k, m in enumerate(names):
        if m == "homography":
            params[..., k, :] = r.reshape(lead + (9,))[..., PERM_FLAT]
        elif m == "mobius":
            params[..., k, :] = mobius_params(_su2_of_rotation(r))
        else:
            axis = r[..., :, 1]
            params[..., k, :] = mobius_params(
                target_shift_matrix((axis[..., 2] + 1j * axis[..., 0]) / axis[..., 1], shift, delta)
            )
    return kinds, params


def mobius_map(R: ArrayLike) -> MobiusMap:
    """z_new -> z_old under the conformal camera's k-transform for the eye rotation R."""
    return MobiusMap(mobius_for_rotation(R))


def target_shift_map(z_target: complex, shift: float, delta: float) -> MobiusMap:
    """z_new -> z_old = z_target + e^{shift delta} z: §6.5's remap into the target-centred frame.

    An affine map, so a ``MobiusMap`` (normalised to determinant 1). ``delta`` (the grid's ring
    spacing) is in (0, 100] and the scale e^{shift delta} within e^{+-40}."""
    zt = complex(checks.array("z_target", z_target, kinds="biufc", shape=()))
    shift = checks.real("shift", shift)
    delta = checks.real("delta", delta, 0.0, 100.0, lo_open=True)
    if abs(shift * delta) > 40:
        raise ValueError(f"shift * delta = {shift * delta:.4g}: the scale e^(shift delta) must lie within e^(+-40)")
    return MobiusMap(target_shift_matrix(zt, shift, delta))


def target_shift_matrix(zt, shift: float, delta: float) -> NDArray[np.complex128]:
    """``target_shift_map``'s 2x2 matrices (..., 2, 2) for targets ``zt`` (...) from already validated
    arguments (|shift delta| <= 40)."""
    root = math.exp(shift * delta / 2)  # sqrt of the scale
    zt = np.asarray(zt, complex)
    out = np.zeros(zt.shape + (2, 2), complex)
    out[..., 0, 0], out[..., 1, 0], out[..., 1, 1] = 1 / root, zt / root, root
    return out


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
    """w(z), with NaN where the map sends a point to infinity (behind the eye).

    A map that raises ``ValueError`` on the whole array is evaluated point by point (points where
    it raises become NaN); one that returns another shape or non-numbers raises."""
    with np.errstate(all="ignore"):
        try:
            w = point_map(z)
        except checks.InputTypeError:
            raise
        except ValueError:
            w = None
        if w is not None:
            w = checks.array("a point map's result", w, kinds="biufc", finite=False)
            if w.shape != z.shape:
                raise ValueError(f"a point map must return one point per input point, shape {z.shape}; got {w.shape}")
            return w.astype(complex)
        w = np.full(z.shape, np.nan + 0j)
        for i, zi in enumerate(z):
            try:
                wi = checks.array("a point map's result", point_map(np.array([zi])), kinds="biufc", finite=False)
            except checks.InputTypeError:
                raise
            except ValueError:
                continue
            if wi.shape != (1,):
                raise ValueError(f"a point map must return one point per input point, shape (1,); got {wi.shape}")
            w[i] = complex(wi[0])
        return w


def predict_many(
    coeffs: ArrayLike,
    fovea: ArrayLike,
    grid: RetinaGrid,
    point_maps: list[PointMap],
    *,
    on: RetinaGrid | None = None,
    dtype: DTypeLike = np.float64,
) -> list[RetinaSamples]:
    """``predict`` for several point maps at once, sharing one evaluation of the series.

    ``dtype=np.float32`` evaluates the series in single precision (~1e-6 relative; a few times
    faster, see ``OffGridEvaluator``)."""
    F = _check_samples(coeffs, grid, "coeffs", complex_ok=True)
    fov = checks.array("fovea", fovea, kinds="biuf", ndim=(1, 2)).astype(float)
    if fov.shape != (grid.n_fovea,) + F.shape[2:]:
        raise ValueError(
            f"fovea must have shape (N_f[, C]) = {(grid.n_fovea,) + F.shape[2:]} (the channels of coeffs); "
            f"got {fov.shape}"
        )
    out_grid = grid if on is None else _check_grid(on, "on")
    dt = _check_float_dtype(dtype)
    if isinstance(point_maps, (str, bytes)) or not hasattr(point_maps, "__len__") or len(point_maps) == 0:
        raise checks.InputTypeError(f"point_maps must be a non-empty list of point maps; got {point_maps!r}")
    for pm in point_maps:
        checks.callable_("each point map", pm)
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
        out[in_periph] = OffGridEvaluator(grid, w[in_periph], dtype=dt)(F)
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
