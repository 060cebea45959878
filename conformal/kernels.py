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
* ``map_footprints``, ``tabulate_angles_pooled``, ``contract_rings_pooled``: the same prediction
  averaged over each new receptive field (``RemapPlan``'s ``pooled=True``): each field's footprint
  carried through the map's Jacobian, the series damped by the matching Gaussian per point.
  Reference: the damped series written out in numpy with finite-difference Jacobians, and the
  sub-point average of the series over each field (``tests/test_remap_pooled.py``).

Kernels are compiled on first use and cached on disk (numba ``cache=True``), so a new process
pays only for loading them. They hold no Python objects and release the GIL.
"""

from __future__ import annotations

import math
import warnings

import numba as nb
import numpy as np

from .maps import KIND_MOBIUS, KIND_PROJECTIVE, behind, homography_plane, homography_weight, is_pole, mobius_parts

__all__ = [
    "DISK_CACHE",
    "KIND_PROJECTIVE",
    "KIND_MOBIUS",
    "pool_picture",
    "series_table",
    "map_points",
    "tabulate_angles",
    "contract_rings",
    "normalized_errors",
    "map_footprints",
    "tabulate_angles_pooled",
    "contract_rings_pooled",
]


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
        warnings.warn(
            f"conformal: numba cannot cache compiled kernels on disk ({e}); they will be compiled "
            "in every process (about 2.5 s). Set NUMBA_CACHE_DIR to a writable folder to cache them.",
            RuntimeWarning,
            stacklevel=2,
        )
        return False
    return True


#: True when the kernels are cached on disk (see ``_disk_cache_available``).
DISK_CACHE = _disk_cache_available()

# Reassociation lets the sums vectorise; no "nnan"/"ninf": the kernels test for poles.
_jit = nb.njit(cache=DISK_CACHE, nogil=True, fastmath={"reassoc", "contract", "arcp", "nsz"})
# conformal.maps' scalar formulas (the point maps and their pole rule), compiled inline into the kernels
_inline = nb.njit(cache=DISK_CACHE, nogil=True, inline="always")
_mobius_parts = _inline(mobius_parts)
_homography_weight = _inline(homography_weight)
_homography_plane = _inline(homography_plane)
_is_pole = _inline(is_pole)
_behind = _inline(behind)


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
def map_points(
    zr, zi, kinds, params, r0, r_outer, fovea_pictures, fovea_spacing, values, valid, series, wr, wi, r2
):  # pragma: no cover - compiled
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
                # conformal.maps' point maps and pole rule, divided only where seen
                if kinds[k] == KIND_PROJECTIVE:
                    w3 = _homography_weight(p, x, y)
                    if _behind(w3):
                        ok = False
                    else:
                        nu, nv = _homography_plane(p, x, y)
                        u = nu / w3
                        v = nv / w3
                else:
                    nr, ni, dr, di = _mobius_parts(p, x, y)
                    den = dr * dr + di * di
                    if _is_pole(den):
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


@_inline
def _start_angles(wr, wi, r2, e, cos_theta0, sin_theta0, re, im, rot_c, rot_s):  # pragma: no cover - compiled
    """Eye e's rotations e^{i y_p} = (w_p / |w_p|) e^{-i theta_0} as (rot_c, rot_s), and (re, im) = e^{i 0 y_p}."""
    for p in range(re.shape[0]):
        inv = 1.0 / math.sqrt(r2[e, p])
        x = wr[e, p] * inv
        y = wi[e, p] * inv
        rot_c[p] = x * cos_theta0 + y * sin_theta0
        rot_s[p] = y * cos_theta0 - x * sin_theta0
        re[p] = 1.0
        im[p] = 0.0


@_inline
def _next_angle(re, im, rot_c, rot_s, p):  # pragma: no cover - compiled
    """(re, im)[p] = e^{i n y_p} -> e^{i (n + 1) y_p}: one step of the rotation."""
    a = re[p] * rot_c[p] - im[p] * rot_s[p]
    im[p] = re[p] * rot_s[p] + im[p] * rot_c[p]
    re[p] = a


@_inline
def _start_rings(partial, e, acc):  # pragma: no cover - compiled
    """acc = the m = 0 term of eye e's ring sum (cos(0) = 1)."""
    for c in range(acc.shape[0]):
        for p in range(acc.shape[1]):
            acc[c, p] = partial[e, c, p]


@_inline
def _add_ring(acc, factor, partial, e, m):  # pragma: no cover - compiled
    """acc[c, p] += factor[p] partial[e, m C + c, p]: ring frequency m's term of eye e's ring sum."""
    n_ch = acc.shape[0]
    for c in range(n_ch):
        row = m * n_ch + c
        for p in range(acc.shape[1]):
            acc[c, p] += factor[p] * partial[e, row, p]


@_inline
def _next_ring(cos_t, e, prev, cur, p):  # pragma: no cover - compiled
    """cos((m + 1) t_p) = 2 cos(t_p) cos(m t_p) - cos((m - 1) t_p) (Chebyshev), stepped in (prev, cur)."""
    nxt = 2.0 * cos_t[e, p] * cur[p] - prev[p]
    prev[p] = cur[p]
    cur[p] = nxt
    return nxt


@_inline
def _add_series(acc, series, e, values):  # pragma: no cover - compiled
    """values[e, k, i] += acc[:, k P + i] where the series is evaluated (``series[e, k, i]``)."""
    n_maps, n_pts = series.shape[1], series.shape[2]
    for k in range(n_maps):
        for i in range(n_pts):
            if series[e, k, i]:
                for c in range(acc.shape[0]):
                    values[e, k, i, c] += acc[c, k * n_pts + i]


@_jit
def tabulate_angles(wr, wi, r2, cos_theta0, sin_theta0, cs):  # pragma: no cover - compiled
    """The angular factor table of the mirror series at the mapped points, points last:
    cs[e, n, p] = cos(n y_p) and cs[e, nh + n, p] = -sin(n y_p) (n < nh), e^{i y} = (w / |w|) e^{-i theta_0},
    by repeated rotation in double precision, row by row (vectorised over p)."""
    n_eyes, n_j, n_cols = cs.shape
    nh = n_j // 2
    re, im, rot_c, rot_s = np.empty(n_cols), np.empty(n_cols), np.empty(n_cols), np.empty(n_cols)
    for e in range(n_eyes):
        _start_angles(wr, wi, r2, e, cos_theta0, sin_theta0, re, im, rot_c, rot_s)
        for n in range(nh):
            for p in range(n_cols):
                cs[e, n, p] = re[p]
                cs[e, nh + n, p] = -im[p]
                _next_angle(re, im, rot_c, rot_s, p)


@_jit
def contract_rings(cos_t, partial, series, values):  # pragma: no cover - compiled
    """values[e, k, i, c] += sum_m cos(m t_p) partial[e, m C + c, p] at p = k P + i where series[e, k, i].

    ``partial`` = (weighted series coefficients (M C, J)) @ cs: the angular sum done. cos(m t)
    comes from ``cos_t`` by the Chebyshev recurrence (double precision, vectorised over p).
    """
    n_eyes, n_maps, n_pts = series.shape
    n_ch, n_cols = values.shape[3], n_maps * n_pts
    # the sums (C, K P) and cos((m - 1) t), cos(m t), allocated here, not in a helper: LLVM then sees that
    # they alias nothing and vectorises the sums
    acc, prev, cur = np.empty((n_ch, n_cols)), np.empty(n_cols), np.empty(n_cols)
    m_rings = partial.shape[1] // n_ch
    for e in range(n_eyes):
        _start_rings(partial, e, acc)
        for p in range(n_cols):
            prev[p] = 1.0
            cur[p] = cos_t[e, p]
        for m in range(1, m_rings):
            _add_ring(acc, cur, partial, e, m)
            for p in range(n_cols):
                _next_ring(cos_t, e, prev, cur, p)
        _add_series(acc, series, e, values)


@nb.njit(inline="always")
def _map_jacobian(kind, p, x, y):  # pragma: no cover - compiled
    """w = map(z) and its Jacobian (d(Re w, Im w) / d(x, y)) at z = x + i y, for a point that
    ``map_points`` found valid (no pole)."""
    if kind == KIND_PROJECTIVE:
        nu, nv = _homography_plane(p, x, y)
        inv = 1.0 / _homography_weight(p, x, y)
        u = nu * inv
        v = nv * inv
        return u, v, (p[0] - u * p[6]) * inv, (p[1] - u * p[7]) * inv, (p[3] - v * p[6]) * inv, (p[4] - v * p[7]) * inv
    # w = (d z + c) / (b z + a), w' = (a d - b c) / (b z + a)^2
    nr, ni, dr, di = _mobius_parts(p, x, y)
    inv = 1.0 / (dr * dr + di * di)
    u = (nr * dr + ni * di) * inv
    v = (ni * dr - nr * di) * inv
    detr = (p[0] * p[6] - p[1] * p[7]) - (p[2] * p[4] - p[3] * p[5])
    deti = (p[0] * p[7] + p[1] * p[6]) - (p[2] * p[5] + p[3] * p[4])
    sr = dr * dr - di * di  # (b z + a)^2, of modulus 1 / inv
    si = 2.0 * dr * di
    inv2 = inv * inv
    gr = (detr * sr + deti * si) * inv2
    gi = (deti * sr - detr * si) * inv2
    return u, v, gr, -gi, gi, gr


@nb.njit(inline="always")
def _carry(foot, i, j00, j01, j10, j11):  # pragma: no cover - compiled
    """S = J F J^T for F = foot[i] = (Sxx, Sxy, Syy): (Sxx, Sxy, Syy) of S."""
    fxx = foot[i, 0]
    fxy = foot[i, 1]
    fyy = foot[i, 2]
    a0 = j00 * fxx + j01 * fxy
    a1 = j00 * fxy + j01 * fyy
    b0 = j10 * fxx + j11 * fxy
    b1 = j10 * fxy + j11 * fyy
    return a0 * j00 + a1 * j01, a0 * j10 + a1 * j11, b0 * j10 + b1 * j11


_INV_SQRT2 = 1.0 / math.sqrt(2.0)
_INV_SQRT2PI = 1.0 / math.sqrt(2.0 * math.pi)


@nb.njit(inline="always")
def _ramp(x, sigma):  # pragma: no cover - compiled
    """max(x, 0) smoothed by a Gaussian of deviation sigma > 0: x Phi(x / sigma) + sigma phi(x / sigma)."""
    t = x / sigma
    return x * 0.5 * math.erfc(-t * _INV_SQRT2) + sigma * _INV_SQRT2PI * math.exp(-0.5 * t * t)


@nb.njit(inline="always")
def _tent_weights(c, sigma, size, ramp, out):  # pragma: no cover - compiled
    """Weights of the lattice nodes n = lo..hi (returned) along one axis for the bilinear interpolant
    at c averaged over a Gaussian of deviation sigma: the tent max(0, 1 - |n - c|) convolved with the
    Gaussian (the second difference of the smoothed ramp), nodes within 1 + 3 sigma; sigma = 0 gives
    the bilinear weights. ``ramp`` is scratch of at least size + 2."""
    lo = max(int(math.ceil(c - 1.0 - 3.0 * sigma)), 0)
    hi = min(int(math.floor(c + 1.0 + 3.0 * sigma)), size - 1)
    if sigma <= 1e-9:
        for n in range(lo, hi + 1):
            out[n] = max(1.0 - abs(n - c), 0.0)
        return lo, hi
    for j in range(hi - lo + 3):  # the ramp at n - c for n = lo - 1 .. hi + 1
        ramp[j] = _ramp(lo - 1 + j - c, sigma)
    for n in range(lo, hi + 1):
        j = n - lo
        out[n] = max(ramp[j + 2] - 2.0 * ramp[j + 1] + ramp[j], 0.0)
    return lo, hi


@_jit
def map_footprints(
    zr,
    zi,
    foot,
    kinds,
    params,
    series,
    valid,
    wr,
    wi,
    r2,
    own_u,
    own_y,
    own_f,
    t_scale2,
    lim_t,
    lim_y,
    fovea_pictures,
    lattice,
    fovea_spacing,
    values,
    rho_t,
    rho_y,
):  # pragma: no cover - compiled
    """Each receptive field's footprint through the point maps (after ``map_points``): the Gaussian
    damping factors of the pooled series and, for fields landing in the old fovea, the pooled lookup.

    ``foot[i]`` = (Sxx, Sxy, Syy): the second moments of field i about its centre z_i (image-plane
    units). The map's Jacobian J at z_i carries them to S = J foot J^T about w = map(z_i). Where
    the series is evaluated (``series``), S in the old log-polar coordinates, less an old field's own
    variances ``own_u``, ``own_y`` (floored at 0), gives the variances s_t = t_scale2 Var(u) (in the
    series' ring argument t) and s_y = Var(theta), each capped at ``lim_t`` / ``lim_y``; then
    rho_t = exp(-s_t / 2) and rho_y = exp(-s_y / 2) (the damping of frequency f is rho^(f^2)).
    Elsewhere rho = 1. Where w lands in the old fovea (valid but not ``series``), ``values`` becomes
    the bilinear interpolant of the lattice samples averaged over the Gaussian of variances Sxx, Syy
    in lattice cells less ``own_f`` (floored at 0; the x-y covariance dropped, as the series' u-theta
    one), normalised by the same average of the lattice's indicator (``lattice``): with nothing left
    to average, the bilinear value itself.
    """
    n_eyes, n_maps, n_pts = valid.shape
    n_ch = values.shape[3]
    size = fovea_pictures.shape[1]
    half = size / 2
    h2 = fovea_spacing * fovea_spacing
    wcol = np.zeros(size)
    wrow = np.zeros(size)
    ramp = np.empty(size + 3)
    for e in range(n_eyes):
        for k in range(n_maps):
            p = params[e, k]
            kind = kinds[k]
            base = k * n_pts
            for i in range(n_pts):  # the series' points: the variances (rho_t, rho_y hold them for now)
                col_index = base + i
                if not series[e, k, i]:
                    rho_t[e, col_index] = 0.0
                    rho_y[e, col_index] = 0.0
                    continue
                u, v, j00, j01, j10, j11 = _map_jacobian(kind, p, zr[i], zi[i])
                sxx, sxy, syy = _carry(foot, i, j00, j01, j10, j11)
                wu = wr[e, col_index]
                wv = wi[e, col_index]
                q = r2[e, col_index]
                inv_q2 = 1.0 / (q * q)
                var_u = (wu * wu * sxx + 2.0 * wu * wv * sxy + wv * wv * syy) * inv_q2 - own_u
                var_y = (wv * wv * sxx - 2.0 * wu * wv * sxy + wu * wu * syy) * inv_q2 - own_y
                rho_t[e, col_index] = min(max(var_u, 0.0) * t_scale2, lim_t)
                rho_y[e, col_index] = min(max(var_y, 0.0), lim_y)
            for i in range(n_pts):  # the old fovea's points: the pooled lookup
                if series[e, k, i] or not valid[e, k, i]:
                    continue
                u, v, j00, j01, j10, j11 = _map_jacobian(kind, p, zr[i], zi[i])
                sxx, sxy, syy = _carry(foot, i, j00, j01, j10, j11)
                col = u / fovea_spacing + half - 0.5  # lattice units, rows downwards
                row = half - 0.5 - v / fovea_spacing
                c_lo, c_hi = _tent_weights(col, math.sqrt(max(sxx / h2 - own_f, 0.0)), size, ramp, wcol)
                r_lo, r_hi = _tent_weights(row, math.sqrt(max(syy / h2 - own_f, 0.0)), size, ramp, wrow)
                total = 0.0
                for rr in range(r_lo, r_hi + 1):
                    for cc in range(c_lo, c_hi + 1):
                        if lattice[rr, cc]:
                            total += wrow[rr] * wcol[cc]
                if total <= 1e-12:  # (no lattice sample nearby: keep the point lookup)
                    continue
                for c in range(n_ch):
                    acc = 0.0
                    for rr in range(r_lo, r_hi + 1):
                        for cc in range(c_lo, c_hi + 1):
                            if lattice[rr, cc]:
                                acc += wrow[rr] * wcol[cc] * fovea_pictures[e, rr, cc, c]
                    values[e, k, i, c] = acc / total
        for col_index in range(rho_t.shape[1]):  # variances -> damping factors (vectorised)
            rho_t[e, col_index] = math.exp(-0.5 * rho_t[e, col_index])
            rho_y[e, col_index] = math.exp(-0.5 * rho_y[e, col_index])


@_jit
def tabulate_angles_pooled(wr, wi, r2, cos_theta0, sin_theta0, rho, cs):  # pragma: no cover - compiled
    """``tabulate_angles`` with angular frequency n at point p damped by rho[e, p]^(n^2) (a Gaussian
    of variance -2 ln rho in theta), by the recurrence a_{n+1} = a_n b_n, b_{n+1} = b_n rho^2."""
    n_eyes, n_j, n_cols = cs.shape
    nh = n_j // 2
    re, im, rot_c, rot_s = np.empty(n_cols), np.empty(n_cols), np.empty(n_cols), np.empty(n_cols)
    amp = np.empty(n_cols)
    step = np.empty(n_cols)
    sq = np.empty(n_cols)
    for e in range(n_eyes):
        _start_angles(wr, wi, r2, e, cos_theta0, sin_theta0, re, im, rot_c, rot_s)
        for p in range(n_cols):
            amp[p] = 1.0
            step[p] = rho[e, p]
            sq[p] = rho[e, p] * rho[e, p]
        for n in range(nh):
            for p in range(n_cols):
                cs[e, n, p] = re[p] * amp[p]
                cs[e, nh + n, p] = -im[p] * amp[p]
                _next_angle(re, im, rot_c, rot_s, p)
                amp[p] *= step[p]
                step[p] *= sq[p]


@_jit
def contract_rings_pooled(cos_t, rho, partial, series, values):  # pragma: no cover - compiled
    """``contract_rings`` with ring frequency m at point p damped by rho[e, p]^(m^2) (as
    ``tabulate_angles_pooled``)."""
    n_eyes, n_maps, n_pts = series.shape
    n_ch, n_cols = values.shape[3], n_maps * n_pts
    acc, prev, cur = np.empty((n_ch, n_cols)), np.empty(n_cols), np.empty(n_cols)  # as contract_rings
    m_rings = partial.shape[1] // n_ch
    damped = np.empty(n_cols)
    amp = np.empty(n_cols)
    step = np.empty(n_cols)
    sq = np.empty(n_cols)
    for e in range(n_eyes):
        _start_rings(partial, e, acc)  # m = 0, undamped
        for p in range(n_cols):
            rh = rho[e, p]
            prev[p] = 1.0
            cur[p] = cos_t[e, p]
            amp[p] = rh  # rho^(1^2)
            step[p] = rh * rh * rh  # rho^(2 m + 1) at m = 1
            sq[p] = rh * rh
            damped[p] = cur[p] * rh
        for m in range(1, m_rings):
            _add_ring(acc, damped, partial, e, m)
            for p in range(n_cols):
                nxt = _next_ring(cos_t, e, prev, cur, p)
                amp[p] *= step[p]
                step[p] *= sq[p]
                damped[p] = nxt * amp[p]
        _add_series(acc, series, e, values)


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
