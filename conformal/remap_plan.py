"""``RemapPlan``: the remapping predictions of several point maps for several eyes per frame, fast.

The same prediction as ``predict_many`` (the mirror series of eq. ``dppcc'`` at the mapped
points, the foveal lattice for points landing in the old fovea), organised for a stream of
frames on one grid:

* everything that depends only on the grid is built once: the output points, the linear map
  from DPFT coefficients to the series' coefficients (``dpft._mirror_map``), the foveal lattice indices;
* per frame, one compiled pass maps the points (``kernels.map_points``), one tabulates the
  angular factors (``kernels.tabulate_angles``), one batched BLAS product sums over the
  angular frequencies and one compiled pass over the rings (``kernels.contract_rings``).

The series is evaluated exactly (no interpolation) in single precision: about 1e-6 relative,
far below the retina's sampling error. The point maps must be ``ProjectiveMap`` or
``MobiusMap`` (what ``homography_map``, ``mobius_map`` and ``target_shift_map`` return); use
``predict_many`` for arbitrary callables.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import checks
from .dpft import _mirror_series
from .fovea import fovea_indices
from .grid import RetinaGrid
from .kernels import contract_rings, map_points, tabulate_angles
from .remap import MobiusMap, ProjectiveMap
from .sampling import RetinaSamples
from .threads import blas_threads

__all__ = ["RemapPlan"]


class RemapPlan:
    """Predictions f(w(z)) at the retina points z of ``on`` (default ``grid``) from the DPFT
    coefficients and foveal samples on ``grid``, for E eyes x K point maps at once.

    ``plan(coeffs, fovea, maps)`` with coeffs (E, M, N, C) complex, fovea (E, N_f, C) and
    ``maps[e][k]`` the k-th point map of eye e (each position k of one kind for all eyes)
    returns ``(values, valid)``: values (E, K, P, C) float32 and valid (E, K, P) bool, where
    P = N_f + M N of ``on`` in retina order (the foveal points, then the periphery [k, l]
    row-major, as ``Retina.operator``'s rows). Invalid points (source beyond r_b, behind the
    eye, or at a pole) hold 0. ``samples`` turns them into ``RetinaSamples``.
    """

    def __init__(self, grid: RetinaGrid, *, on: RetinaGrid | None = None) -> None:
        self.grid = grid
        self.on = grid if on is None else on
        if not (isinstance(self.grid, RetinaGrid) and isinstance(self.on, RetinaGrid)):
            raise checks.InputTypeError("grid (and on) must be RetinaGrid objects; got "
                                        f"{type(grid).__name__} (and {type(on).__name__})")
        z = np.concatenate([self.on.fovea_points, self.on.points.ravel()])
        self._zr, self._zi = np.ascontiguousarray(z.real), np.ascontiguousarray(z.imag)
        self.n_points = len(z)
        self._fovea_rows, self._fovea_cols, self._fovea_size = fovea_indices(grid)
        self._scratch: dict[tuple[int, int], tuple[NDArray, ...]] = {}
        self._picture_scratch: dict[tuple[int, int], NDArray] = {}
        self._cos_t: dict[tuple[int, ...], NDArray] = {}
        # per-grid scalars of the per-frame passes (computed as the expressions they replace)
        self._r_outer = grid.ring_edges[-1]
        self._cos_theta0, self._sin_theta0 = math.cos(grid.theta[0]), math.sin(grid.theta[0])
        self._t_scale = math.pi / (grid.M * grid.delta)
        self._t_offset = math.pi / (2 * grid.M)

    # ------------------------------------------------------------------ per frame
    def series_coefficients(self, coeffs: ArrayLike) -> NDArray[np.float32]:
        """The weighted real coefficients of the mirror series, (E, M C, J) float32 with
        J = 2 (N/2 + 1): row m C + c (ring-frequency m, channel c) holds the cosine then the
        sine coefficients of the angular frequencies (as ``OffGridEvaluator``'s real matrix path).
        ``coeffs``: finite (E, M, N, C) DPFT coefficients."""
        return _mirror_series(self._check_coeffs(coeffs), self.grid, np.float32)

    def __call__(
        self, coeffs: ArrayLike, fovea: ArrayLike, maps: Sequence[Sequence[ProjectiveMap | MobiusMap]]
    ) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
        F, fov = self._check(coeffs, fovea)
        kinds, params = self._maps(maps, F.shape[0])
        return self._evaluate(F, fov, kinds, params)

    def _evaluate(
        self, F: NDArray, fov: NDArray, kinds: NDArray[np.int64], params: NDArray[np.float64]
    ) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
        """``__call__`` on arguments that are already valid: F finite (E, M, N, C) coefficients, fov
        finite real (E, N_f, C), kinds (K,) int64 and params (E, K, 9) float64 as ``_maps`` returns
        them. Nothing is checked: for callers that pass what ``_check``/``_maps`` (or an equally
        strict construction of their own) produced."""
        n_eyes, n_ch = F.shape[0], F.shape[3]
        n_maps = len(kinds)
        g = self.grid
        pictures = self._pictures(n_eyes, n_ch)
        pictures[:, self._fovea_rows, self._fovea_cols] = fov
        cs, wr, wi, r2 = self._tables(n_eyes, n_maps)
        values = np.empty((n_eyes, n_maps, self.n_points, n_ch), np.float32)
        valid = np.empty((n_eyes, n_maps, self.n_points), np.bool_)
        series = np.empty((n_eyes, n_maps, self.n_points), np.bool_)
        map_points(self._zr, self._zi, kinds, params, g.r0, self._r_outer, pictures, g.fovea_spacing,
                   values, valid, series, wr, wi, r2)
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
        contract_rings(cos_t, partial, series, values)
        return values, valid

    def samples(self, values: NDArray, valid: NDArray) -> list[list[RetinaSamples]]:
        """``RetinaSamples`` views [eye][map] of a call's result (values in float32)."""
        n_f, o = self.on.n_fovea, self.on
        values = checks.array("values", values, kinds="f", ndim=4, finite=False)
        if values.shape[2] != self.n_points:
            raise ValueError(f"values must be (E, K, P, C) with P = {self.n_points} (a call's result); got {values.shape}")
        valid = checks.array("valid", valid, kinds="b", shape=values.shape[:3])
        return [
            [
                RetinaSamples(
                    fovea=v[:n_f], periphery=v[n_f:].reshape((o.M, o.N) + v.shape[1:]),
                    mask=m[n_f:].reshape(o.M, o.N), fovea_mask=m[:n_f],
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
        if isinstance(maps, (str, bytes)) or not hasattr(maps, "__len__") or any(
                isinstance(m, (str, bytes)) or not hasattr(m, "__iter__") for m in maps):
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
            self._scratch[key] = (np.empty((n_eyes, 2 * nh, cols), np.float32), *(np.empty((n_eyes, cols)) for _ in range(3)))
        return self._scratch[key]
