"""Compiled inner loops (numba) of the per-frame pipeline.

Each kernel is the tight loop of an operation that the tests check against an independent
reference:

* ``pool_picture``: one sparse receptive-field operator times a picture of any dtype, read in
  place (scipy would first copy a uint8 picture to float64, which costs more than the product).
  Reference: scipy's ``Retina.operator @ picture``.
* ``series_table``, ``map_points``, ``tabulate_angles``, ``contract_rings``: the efference-copy
  point maps and the mirror series of eq. ``dppcc'`` at the mapped points (for
  ``RemapPlan``): the angular sum as one BLAS product with a factor table, the sum over rings
  by a recurrence (points last throughout, so the loops vectorise). Reference: the direct sum
  ``evaluate_direct`` at the maps' images, and ``predict_many``.
* ``normalized_errors``: the normalized RMS error of predictions against actual samples.
  Reference: the formula written out in numpy (``tests/test_remap_plan.py``).

Kernels are compiled on first use and cached on disk (numba ``cache=True``), so a new process
pays only for loading them. They hold no Python objects and release the GIL.
"""

from __future__ import annotations

import math
import warnings

import numba as nb
import numpy as np

__all__ = [
    "KIND_PROJECTIVE", "KIND_MOBIUS", "pool_picture", "series_table", "map_points", "tabulate_angles", "contract_rings",
    "normalized_errors",
]

KIND_PROJECTIVE = 0  # params: the 3x3 matrix H row-major, acting on (Re z, Im z, 1)
KIND_MOBIUS = 1  # params: a, b, c, d (re, im) of g . z = (d z + c) / (b z + a), then 0



def _cache_probe() -> int:  # pragma: no cover - compiled only if ever called
    return 0


def _disk_cache_available() -> bool:
    """Whether numba can cache this module's kernels on disk.

    numba looks for a writable ``__pycache__`` beside this file, then for a user-wide cache
    (``NUMBA_CACHE_DIR``, ``$XDG_CACHE_HOME`` or ``~/.cache``); a read-only install with no
    writable home has neither, and ``cache=True`` would then fail at import. Without a cache the
    kernels are compiled in every new process (about 2.5 s) instead.
    """
    try:
        nb.njit(cache=True)(_cache_probe)
    except RuntimeError as e:  # numba: "cannot cache function ...: no locator available"
        warnings.warn(f"conformal: numba cannot cache compiled kernels on disk ({e}); they will be compiled "
                      "in every process (about 2.5 s). Set NUMBA_CACHE_DIR to a writable folder to cache them.",
                      RuntimeWarning, stacklevel=2)
        return False
    return True


#: True when the kernels are cached on disk (see ``_disk_cache_available``).
DISK_CACHE = _disk_cache_available()

# Reassociation lets the sums vectorise; no "nnan"/"ninf": the kernels test for poles.
_jit = nb.njit(cache=DISK_CACHE, nogil=True, fastmath={"reassoc", "contract", "arcp", "nsz"})

_POLE_TOL = 1e-12  # as conformal.geometry


@_jit
def pool_picture(indptr, indices, data, picture, scale, out):  # pragma: no cover - compiled
    """out[r, c] = scale * sum_k data[k] picture[indices[k], c] over row r of a CSR operator.

    picture: (H W, C) of any real dtype; out: (rows, C) float.
    """
    n_ch = picture.shape[1]
    for r in range(indptr.shape[0] - 1):
        if n_ch == 3:  # RGB: the three sums in registers (2x faster than the general loop below)
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            for k in range(indptr[r], indptr[r + 1]):
                j = indices[k]
                w = data[k]
                s0 += w * picture[j, 0]
                s1 += w * picture[j, 1]
                s2 += w * picture[j, 2]
            out[r, 0] = s0 * scale
            out[r, 1] = s1 * scale
            out[r, 2] = s2 * scale
            continue
        for c in range(n_ch):
            out[r, c] = 0.0
        for k in range(indptr[r], indptr[r + 1]):
            j = indices[k]
            w = data[k] * scale
            for c in range(n_ch):
                out[r, c] += w * picture[j, c]


@_jit
def series_table(H, b1, b2, neg, out):  # pragma: no cover - compiled
    """The weighted real coefficients of the mirror series from H = A F (see ``remap_plan``):
    D[q] = H[q] b1[q] + conj(H[neg[q]]) b2[q] for q < nh; out[e, m C + c, q] = Re D and
    out[e, m C + c, nh + q] = Im D. H (E, M, N, C) complex, out (E, M C, 2 nh) float32."""
    n_eyes, m_rings, _, n_ch = H.shape
    nh = b1.shape[0]
    for e in range(n_eyes):
        for m in range(m_rings):
            for c in range(n_ch):
                row = m * n_ch + c
                for q in range(nh):
                    d = H[e, m, q, c] * b1[q] + np.conj(H[e, m, neg[q], c]) * b2[q]
                    out[e, row, q] = d.real
                    out[e, row, nh + q] = d.imag


@_jit
def map_points(zr, zi, kinds, params, r0, r_outer, fovea_pictures, fovea_spacing, values, valid, series, wr, wi, r2):  # pragma: no cover - compiled
    """Map every point through every eye's point maps and sort the images by where they land.

    For eye e, map k and point i (z = zr[i] + i zi[i]) the image w = map_k(z) (``kinds[k]``,
    ``params[e, k]``) goes to column k P + i of ``wr``, ``wi``, ``r2`` (E, K P) and is classified:

    * |w| < r0: the old fovea; ``values[e, k, i]`` = bilinear interpolation of the foveal
      lattice picture ``fovea_pictures[e]`` (as ``conformal.remap._fovea_lookup``);
    * r0 <= |w| < r_outer: the old periphery, for the series: ``series[e, k, i]``;
    * otherwise (beyond r_b, behind the eye, or a pole of the map): ``valid`` is False.

    ``values`` is 0 wherever the fovea does not fill it. Points not for the series get
    w = r0 (a harmless place for the vectorised table passes that follow).
    """
    n_eyes, n_maps, n_pts = valid.shape
    n_ch = values.shape[3]
    size = fovea_pictures.shape[1]
    half = size / 2
    for e in range(n_eyes):
        for k in range(n_maps):
            p = params[e, k]
            for i in range(n_pts):
                col_index = k * n_pts + i
                x = zr[i]
                y = zi[i]
                ok = True
                u = 0.0
                v = 0.0
                if kinds[k] == KIND_PROJECTIVE:
                    w3 = p[6] * x + p[7] * y + p[8]
                    if w3 <= _POLE_TOL:  # behind the old eye (or at infinity)
                        ok = False
                    else:
                        u = (p[0] * x + p[1] * y + p[2]) / w3
                        v = (p[3] * x + p[4] * y + p[5]) / w3
                else:
                    nr = p[6] * x - p[7] * y + p[4]
                    ni = p[6] * y + p[7] * x + p[5]
                    dr = p[2] * x - p[3] * y + p[0]
                    di = p[2] * y + p[3] * x + p[1]
                    den = dr * dr + di * di
                    if den < _POLE_TOL * _POLE_TOL:
                        ok = False
                    else:
                        u = (nr * dr + ni * di) / den
                        v = (ni * dr - nr * di) / den
                rr = u * u + v * v
                for c in range(n_ch):
                    values[e, k, i, c] = 0.0
                inside = ok and r0 * r0 <= rr < r_outer * r_outer
                series[e, k, i] = inside
                valid[e, k, i] = inside
                if inside:
                    wr[e, col_index] = u
                    wi[e, col_index] = v
                    r2[e, col_index] = rr
                    continue
                wr[e, col_index] = r0
                wi[e, col_index] = 0.0
                r2[e, col_index] = r0 * r0
                if ok and rr < r0 * r0:
                    col = u / fovea_spacing + half - 0.5
                    row = half - 0.5 - v / fovea_spacing
                    c0 = min(max(int(math.floor(col)), 0), size - 2)
                    q0 = min(max(int(math.floor(row)), 0), size - 2)
                    fc = min(max(col - c0, 0.0), 1.0)
                    fr = min(max(row - q0, 0.0), 1.0)
                    for c in range(n_ch):
                        values[e, k, i, c] = (
                            fovea_pictures[e, q0, c0, c] * ((1 - fr) * (1 - fc))
                            + fovea_pictures[e, q0, c0 + 1, c] * ((1 - fr) * fc)
                            + fovea_pictures[e, q0 + 1, c0, c] * (fr * (1 - fc))
                            + fovea_pictures[e, q0 + 1, c0 + 1, c] * (fr * fc)
                        )
                    valid[e, k, i] = True


@_jit
def tabulate_angles(wr, wi, r2, cos_theta0, sin_theta0, cs):  # pragma: no cover - compiled
    """The angular factor table of the mirror series at the mapped points, points last:
    cs[e, n, p] = cos(n y_p) and cs[e, nh + n, p] = -sin(n y_p) (n < nh), e^{i y} = (w / |w|) e^{-i theta_0},
    by repeated rotation in double precision, row by row (vectorised over p)."""
    n_eyes, n_j, n_cols = cs.shape
    nh = n_j // 2
    re = np.empty(n_cols)
    im = np.empty(n_cols)
    rot_c = np.empty(n_cols)
    rot_s = np.empty(n_cols)
    for e in range(n_eyes):
        for p in range(n_cols):
            inv = 1.0 / math.sqrt(r2[e, p])
            x = wr[e, p] * inv
            y = wi[e, p] * inv
            rot_c[p] = x * cos_theta0 + y * sin_theta0
            rot_s[p] = y * cos_theta0 - x * sin_theta0
            re[p] = 1.0
            im[p] = 0.0
        for n in range(nh):
            for p in range(n_cols):
                cs[e, n, p] = re[p]
                cs[e, nh + n, p] = -im[p]
                a = re[p] * rot_c[p] - im[p] * rot_s[p]
                im[p] = re[p] * rot_s[p] + im[p] * rot_c[p]
                re[p] = a


@_jit
def contract_rings(cos_t, partial, series, values):  # pragma: no cover - compiled
    """values[e, k, i, c] += sum_m cos(m t_p) partial[e, m C + c, p] at p = k P + i where series[e, k, i].

    ``partial`` = (weighted series coefficients (M C, J)) @ cs: the angular sum done. cos(m t)
    comes from ``cos_t`` by the Chebyshev recurrence (double precision, vectorised over p).
    """
    n_eyes, n_maps, n_pts = series.shape
    n_ch = values.shape[3]
    m_rings = partial.shape[1] // n_ch
    n_cols = n_maps * n_pts
    acc = np.empty((n_ch, n_cols))
    prev = np.empty(n_cols)
    cur = np.empty(n_cols)
    for e in range(n_eyes):
        for c in range(n_ch):
            for p in range(n_cols):
                acc[c, p] = partial[e, c, p]  # m = 0: cos(0) = 1
        for p in range(n_cols):
            prev[p] = 1.0
            cur[p] = cos_t[e, p]
        for m in range(1, m_rings):
            for c in range(n_ch):
                row = m * n_ch + c
                for p in range(n_cols):
                    acc[c, p] += cur[p] * partial[e, row, p]
            for p in range(n_cols):
                nxt = 2.0 * cos_t[e, p] * cur[p] - prev[p]
                prev[p] = cur[p]
                cur[p] = nxt
        for k in range(n_maps):
            for i in range(n_pts):
                if series[e, k, i]:
                    for c in range(n_ch):
                        values[e, k, i, c] += acc[c, k * n_pts + i]


@_jit
def normalized_errors(pred, pred_valid, actual, actual_valid, out):  # pragma: no cover - compiled
    """out[e, k] = RMS(pred - actual) / RMS(actual - mean actual) over points valid in both.

    pred (E, K, P, C), pred_valid (E, K, P), actual (E, P, C), actual_valid (P,); NaN where no
    point is valid, the contrast floored at 1e-12 (as ``envs.vision.normalized_error``).
    """
    n_eyes, n_maps, n_pts, n_ch = pred.shape
    for e in range(n_eyes):
        for k in range(n_maps):
            n = 0
            s_a = 0.0
            for i in range(n_pts):
                if pred_valid[e, k, i] and actual_valid[i]:
                    n += 1
                    for c in range(n_ch):
                        s_a += actual[e, i, c]
            if n == 0:
                out[e, k] = np.nan
                continue
            mean = s_a / (n * n_ch)
            s_d = 0.0
            s_c = 0.0
            for i in range(n_pts):
                if pred_valid[e, k, i] and actual_valid[i]:
                    for c in range(n_ch):
                        a = actual[e, i, c]
                        d = pred[e, k, i, c] - a
                        s_d += d * d
                        s_c += (a - mean) * (a - mean)
            contrast = math.sqrt(s_c / (n * n_ch))
            out[e, k] = math.sqrt(s_d / (n * n_ch)) / max(contrast, 1e-12)
