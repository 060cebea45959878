"""``RemapPlan``: the remapping predictions of several point maps for several eyes per frame, fast.

The same prediction as ``predict_many`` (the mirror series of eq. ``dppcc'`` at the mapped
points, the foveal lattice for points landing in the old fovea), organised for a stream of
frames on one grid: what depends only on the grid (output points, ``dpft.mirror_map``, the foveal
lattice indices) is built once; per frame, compiled passes map the points and tabulate the angular
factors, one batched BLAS product sums over the angular frequencies and a compiled pass contracts
the rings. The series is evaluated exactly in single precision (about 1e-6 relative). The point
maps must be ``ProjectiveMap`` or ``MobiusMap``; use ``predict_many`` for arbitrary callables.

``pooled=True`` averages each new receptive field's footprint (its second moments carried through
the map's Jacobian, less what the old fields' own averaging already holds) over the series, so
detail the old fields never resolved is not restored; about 1.35x the point prediction's time.

The passes, and how the pooled prediction is built: docs/math.md ("The math", section "Remapping a
stream of frames: RemapPlan").
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import checks
from .dpft import _mirror_series
from .fovea import fovea_indices
from .grid import RetinaGrid
from .kernels import (
    contract_rings,
    contract_rings_pooled,
    map_footprints,
    map_points,
    tabulate_angles,
    tabulate_angles_pooled,
)
from .remap import MobiusMap, ProjectiveMap
from .sampling import RetinaSamples
from .threads import blas_threads

__all__ = ["RemapPlan", "field_moments"]

#: The pooled damping rho^(f^2) of the highest frequency f stops at e^-40 (4e-18): beyond that a
#: term is zero for any purpose, and float32 tables stay clear of subnormal numbers.
_MAX_DAMPING_EXPONENT = 40.0


def field_moments(grid: RetinaGrid) -> NDArray[np.float64]:
    """Second moments of every receptive field of ``grid`` about its sample point, as the pooled
    retina (``Retina``'s ``"pool"``) averages: (N_f + M N, 3) = (Sxx, Sxy, Syy) in image-plane
    units^2 (x = Re z, y = Im z), rows in retina order (the foveal points, then the periphery [k, l]
    row-major).

    A foveal field is the square of side 1/K around its lattice point: h^2/12 on each axis. A
    peripheral field is the annular sector r_k <= r < r_{k+1}, |phi - theta_l| < pi/N, uniform in
    area: in its radial/tangential frame the moments about the sample point z_{k,l} (radius
    ``grid.radii[k]``) are E[(x_r - |z|)^2] and E[x_t^2] with no cross term, rotated by theta_l.
    Read-only, computed once per grid."""
    if not isinstance(grid, RetinaGrid):
        raise checks.InputTypeError(f"grid must be a RetinaGrid; got {type(grid).__name__}")
    return _field_moments(grid)


@lru_cache(maxsize=32)
def _field_moments(grid: RetinaGrid) -> NDArray[np.float64]:
    r1, r2 = grid.ring_edges[:-1], grid.ring_edges[1:]
    a = math.pi / grid.N  # half the sector's angle
    area = a * (r2**2 - r1**2)
    m1 = 2 * math.sin(a) * (r2**3 - r1**3) / 3 / area  # E[x_r]
    m2r = (a + math.sin(2 * a) / 2) * (r2**4 - r1**4) / 4 / area  # E[x_r^2]
    m2t = (a - math.sin(2 * a) / 2) * (r2**4 - r1**4) / 4 / area  # E[x_t^2]
    rc = grid.radii
    var_r = (m2r - 2 * rc * m1 + rc**2)[:, None]  # about the sample point
    var_t = m2t[:, None]
    c, s = np.cos(grid.theta)[None, :], np.sin(grid.theta)[None, :]
    per = np.stack([var_r * c * c + var_t * s * s, (var_r - var_t) * c * s, var_r * s * s + var_t * c * c], -1)
    fov = np.zeros((grid.n_fovea, 3))
    fov[:, 0] = fov[:, 2] = grid.fovea_spacing**2 / 12
    out = np.concatenate([fov, per.reshape(-1, 3)])
    out.setflags(write=False)
    return out


class RemapPlan:
    """Predictions f(w(z)) at the retina points z of ``on`` (default ``grid``) from the DPFT
    coefficients and foveal samples on ``grid``, for E eyes x K point maps at once.

    ``plan(coeffs, fovea, maps)`` with coeffs (E, M, N, C) complex, fovea (E, N_f, C) and
    ``maps[e][k]`` the k-th point map of eye e (each position k of one kind for all eyes)
    returns ``(values, valid)``: values (E, K, P, C) float32 and valid (E, K, P) bool, where
    P = N_f + M N of ``on`` in retina order (the foveal points, then the periphery [k, l]
    row-major, as ``Retina.operator``'s rows). Invalid points (source beyond r_b, behind the
    eye, or at a pole) hold 0. ``samples`` turns them into ``RetinaSamples``.

    ``pooled`` (a bool, default False: the point prediction, unchanged): average each prediction
    over its receptive field of ``on``, less what the old fields' own averaging already holds (see
    the module docstring), as the pooled retina averages the picture; about 1.35x the point
    prediction's time, and closer to the pooled post-saccadic samples (``benchmarks/remap_pooling.py``).
    """

    def __init__(self, grid: RetinaGrid, *, on: RetinaGrid | None = None) -> None:
        self.grid = grid
        self.on = grid if on is None else on
        if not (isinstance(self.grid, RetinaGrid) and isinstance(self.on, RetinaGrid)):
            raise checks.InputTypeError(
                f"grid (and on) must be RetinaGrid objects; got {type(grid).__name__} (and {type(on).__name__})"
            )
        z = np.concatenate([self.on.fovea_points, self.on.points.ravel()])
        self._zr, self._zi = np.ascontiguousarray(z.real), np.ascontiguousarray(z.imag)
        self.n_points = len(z)
        self._fovea_rows, self._fovea_cols, self._fovea_size = fovea_indices(grid)
        self._scratch: dict[tuple, tuple[NDArray, ...]] = {}
        self._picture_scratch: dict[tuple[int, int], NDArray] = {}
        self._cos_t: dict[tuple[int, ...], NDArray] = {}
        # per-grid scalars of the per-frame passes (computed as the expressions they replace)
        self._r_outer = grid.ring_edges[-1]
        self._cos_theta0, self._sin_theta0 = math.cos(grid.theta[0]), math.sin(grid.theta[0])
        self._t_scale = math.pi / (grid.M * grid.delta)
        self._t_offset = math.pi / (2 * grid.M)
        # pooled predictions: the fields' moments, the damping caps, the foveal lattice's cells
        self._moments = _field_moments(self.on)
        self._lim_t = 2 * _MAX_DAMPING_EXPONENT / max(grid.M - 1, 1) ** 2
        self._lim_y = 2 * _MAX_DAMPING_EXPONENT / max(grid.N // 2, 1) ** 2
        # an old field's own variances (the same in every ring: the grid is self-similar): in u and
        # theta for a peripheral one, in lattice cells^2 for a foveal one
        own = _field_moments(grid)[grid.n_fovea]  # ring 0, sector 0, about its centre
        c0, s0 = math.cos(grid.theta[0]), math.sin(grid.theta[0])
        self._own_u = (c0 * c0 * own[0] + 2 * c0 * s0 * own[1] + s0 * s0 * own[2]) / grid.radii[0] ** 2
        self._own_y = (s0 * s0 * own[0] - 2 * c0 * s0 * own[1] + c0 * c0 * own[2]) / grid.radii[0] ** 2
        self._own_f = 1.0 / 12.0
        self._lattice = np.zeros((self._fovea_size, self._fovea_size), np.bool_)
        self._lattice[self._fovea_rows, self._fovea_cols] = True

    # ------------------------------------------------------------------ per frame
    def series_coefficients(self, coeffs: ArrayLike) -> NDArray[np.float32]:
        """The weighted real coefficients of the mirror series, (E, M C, J) float32 with
        J = 2 (N/2 + 1): row m C + c (ring-frequency m, channel c) holds the cosine then the
        sine coefficients of the angular frequencies (as ``OffGridEvaluator``'s real matrix path).
        ``coeffs``: finite (E, M, N, C) DPFT coefficients."""
        return _mirror_series(self._check_coeffs(coeffs), self.grid, np.float32)

    def __call__(
        self,
        coeffs: ArrayLike,
        fovea: ArrayLike,
        maps: Sequence[Sequence[ProjectiveMap | MobiusMap]],
        *,
        pooled: bool = False,
    ) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
        pooled = checks.flag("pooled", pooled)
        F, fov = self._check(coeffs, fovea)
        kinds, params = self._maps(maps, F.shape[0])
        return self.evaluate_prechecked(F, fov, kinds, params, pooled)

    def evaluate_prechecked(
        self, F: NDArray, fov: NDArray, kinds: NDArray[np.int64], params: NDArray[np.float64], pooled: bool = False
    ) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
        """``__call__`` on arguments that are already valid: F finite (E, M, N, C) coefficients, fov
        finite real (E, N_f, C), kinds (K,) int64 and params (E, K, 9) float64 as ``_maps`` returns
        them, ``pooled`` a bool. Nothing is checked: for callers that pass what ``_check``/``_maps``
        (or an equally strict construction of their own) produced."""
        n_eyes, n_ch = F.shape[0], F.shape[3]
        n_maps = len(kinds)
        g = self.grid
        pictures = self._pictures(n_eyes, n_ch)
        pictures[:, self._fovea_rows, self._fovea_cols] = fov
        cs, wr, wi, r2 = self._tables(n_eyes, n_maps)
        values = np.empty((n_eyes, n_maps, self.n_points, n_ch), np.float32)
        valid = np.empty((n_eyes, n_maps, self.n_points), np.bool_)
        series = np.empty((n_eyes, n_maps, self.n_points), np.bool_)
        map_points(
            self._zr,
            self._zi,
            kinds,
            params,
            g.r0,
            self._r_outer,
            pictures,
            g.fovea_spacing,
            values,
            valid,
            series,
            wr,
            wi,
            r2,
        )
        if pooled:
            rho_t, rho_y = self._damping(n_eyes, n_maps)
            map_footprints(
                self._zr,
                self._zi,
                self._moments,
                kinds,
                params,
                series,
                valid,
                wr,
                wi,
                r2,
                self._own_u,
                self._own_y,
                self._own_f,
                self._t_scale**2,
                self._lim_t,
                self._lim_y,
                pictures,
                self._lattice,
                g.fovea_spacing,
                values,
                rho_t,
                rho_y,
            )
            tabulate_angles_pooled(wr, wi, r2, self._cos_theta0, self._sin_theta0, rho_y, cs)
        else:
            tabulate_angles(wr, wi, r2, self._cos_theta0, self._sin_theta0, cs)
        with blas_threads(1):  # a small product: a second BLAS thread only fights other work for the core
            partial = np.matmul(_mirror_series(F, g, np.float32), cs)  # (E, M C, K P): the angular sum
        # t = pi (2 (fractional ring index) + 1) / 2M, the DCT-II basis' argument (in place, the
        # same operations in the same order as np.cos((0.5 log r2 - u_0) pi / (M delta) + pi / 2M))
        cos_t = self._cos_t_scratch(r2.shape)
        np.log(r2, out=cos_t)
        cos_t *= 0.5
        cos_t -= g.u[0]
        cos_t *= self._t_scale
        cos_t += self._t_offset
        np.cos(cos_t, out=cos_t)
        if pooled:
            contract_rings_pooled(cos_t, rho_t, partial, series, values)
        else:
            contract_rings(cos_t, partial, series, values)
        return values, valid

    def samples(self, values: NDArray, valid: NDArray) -> list[list[RetinaSamples]]:
        """``RetinaSamples`` views ``[eye][map]`` of a call's result (values in float32)."""
        n_f, o = self.on.n_fovea, self.on
        values = checks.array("values", values, kinds="f", ndim=4, finite=False)
        if values.shape[2] != self.n_points:
            raise ValueError(
                f"values must be (E, K, P, C) with P = {self.n_points} (a call's result); got {values.shape}"
            )
        valid = checks.array("valid", valid, kinds="b", shape=values.shape[:3])
        return [
            [
                RetinaSamples(
                    fovea=v[:n_f],
                    periphery=v[n_f:].reshape((o.M, o.N) + v.shape[1:]),
                    mask=m[n_f:].reshape(o.M, o.N),
                    fovea_mask=m[:n_f],
                )
                for v, m in zip(ve, me)
            ]
            for ve, me in zip(values, valid)
        ]

    # ------------------------------------------------------------------ helpers
    def _check_coeffs(self, coeffs: ArrayLike) -> NDArray:
        g = self.grid
        F = checks.array("coeffs", coeffs, kinds="biufc", finite=False)
        if F.ndim != 4 or F.shape[1:3] != (g.M, g.N) or 0 in F.shape:
            raise ValueError(f"coeffs must be (E, M, N, C) = (E, {g.M}, {g.N}, C) numbers; got shape {F.shape}")
        if not np.all(np.isfinite(F)):
            raise ValueError("coeffs and fovea must be finite (no NaN or infinity)")
        return F

    def _check(self, coeffs: ArrayLike, fovea: ArrayLike) -> tuple[NDArray, NDArray]:
        g = self.grid
        F = self._check_coeffs(coeffs)
        fov = checks.array("fovea", fovea, kinds="biuf", finite=False)
        if fov.shape != (F.shape[0], g.n_fovea, F.shape[3]):
            raise ValueError(
                f"fovea must be real (E, N_f, C) = ({F.shape[0]}, {g.n_fovea}, {F.shape[3]}); got shape {fov.shape}"
            )
        if not np.all(np.isfinite(fov)):
            raise ValueError("coeffs and fovea must be finite (no NaN or infinity)")
        return F, fov

    def _maps(self, maps, n_eyes: int) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        if (
            isinstance(maps, (str, bytes))
            or not hasattr(maps, "__len__")
            or any(isinstance(m, (str, bytes)) or not hasattr(m, "__iter__") for m in maps)
        ):
            raise checks.InputTypeError(f"maps must be a list (one per eye) of lists of point maps; got {maps!r:.80}")
        if len(maps) != n_eyes:
            raise ValueError(f"maps must hold one list of point maps per eye ({n_eyes}); got {len(maps)}")
        per_eye = [list(m) for m in maps]
        n_maps = len(per_eye[0])
        if n_maps == 0 or any(len(m) != n_maps for m in per_eye):
            raise ValueError("every eye needs the same, non-zero number of point maps")
        for m in per_eye:
            for pm in m:
                if not isinstance(pm, (ProjectiveMap, MobiusMap)):
                    raise checks.InputTypeError(
                        f"RemapPlan needs ProjectiveMap or MobiusMap point maps (homography_map, mobius_map and "
                        f"target_shift_map make them); got {type(pm).__name__}: use predict_many for other maps"
                    )
        kinds = np.array([pm.kind for pm in per_eye[0]], np.int64)
        if any(pm.kind != k for m in per_eye for pm, k in zip(m, kinds)):
            raise ValueError("the k-th point map must be of the same kind for every eye")
        params = np.array([[pm.params for pm in m] for m in per_eye], np.float64)
        return kinds, params

    def _pictures(self, n_eyes: int, n_ch: int) -> NDArray[np.float64]:
        """The foveal lattice pictures (E, S, S, C), reused across frames: zero off the lattice
        (only the lattice cells are ever written)."""
        key = (n_eyes, n_ch)
        if key not in self._picture_scratch:
            self._picture_scratch[key] = np.zeros((n_eyes, self._fovea_size, self._fovea_size, n_ch))
        return self._picture_scratch[key]

    def _damping(self, n_eyes: int, n_maps: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Scratch arrays (E, K P) for the pooled damping factors rho_t, rho_y, reused across frames."""
        key = ("damping", n_eyes, n_maps)
        if key not in self._scratch:
            cols = n_maps * self.n_points
            self._scratch[key] = (np.empty((n_eyes, cols)), np.empty((n_eyes, cols)))
        rho_t, rho_y = self._scratch[key]
        return rho_t, rho_y

    def _cos_t_scratch(self, shape: tuple[int, ...]) -> NDArray[np.float64]:
        if shape not in self._cos_t:
            self._cos_t[shape] = np.empty(shape)
        return self._cos_t[shape]

    def _tables(self, n_eyes: int, n_maps: int) -> tuple[NDArray, ...]:
        """Scratch arrays reused across frames of the same (E, K): the angular factor table
        cs (E, J, K P) float32 and the mapped points' Re, Im and |w|^2 (E, K P)."""
        key = (n_eyes, n_maps)
        if key not in self._scratch:
            cols = n_maps * self.n_points
            nh = self.grid.N // 2 + 1
            self._scratch[key] = (
                np.empty((n_eyes, 2 * nh, cols), np.float32),
                *(np.empty((n_eyes, cols)) for _ in range(3)),
            )
        return self._scratch[key]
