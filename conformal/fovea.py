"""The foveal transform (§6.1, §6.5.1): a Euclidean DFT of the uniform foveal samples.

The fovea is the disc |z| < r0 sampled on a square lattice of spacing 1/K (the N_f lattice
points nearest the fixation point, ``RetinaGrid.fovea_points``). Embedded in the smallest
P x P lattice square that holds them (zeros outside the disc), it is transformed by the
ordinary 2-D DFT, the Fourier transform of the Euclidean subgroup the paper proposes.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import checks
from .grid import RetinaGrid

__all__ = ["fovea_indices", "fovea_image", "fovea_dft", "fovea_idft"]


def fovea_indices(grid: RetinaGrid) -> tuple[NDArray[np.intp], NDArray[np.intp], int]:
    """(row, col) of each foveal sample in the P x P lattice picture (row 0 on top), and P.
    Computed once per grid (read-only arrays)."""
    if not isinstance(grid, RetinaGrid):
        raise checks.InputTypeError(f"grid must be a RetinaGrid; got {type(grid).__name__}")
    return _fovea_indices(grid)


@lru_cache(maxsize=32)
def _fovea_indices(grid: RetinaGrid) -> tuple[NDArray[np.intp], NDArray[np.intp], int]:
    p = grid.fovea_points / grid.fovea_spacing
    half = int(np.ceil(max(np.abs(p.real).max(), np.abs(p.imag).max())))
    size = 2 * half
    col = np.round(p.real + half - 0.5).astype(np.intp)
    row = np.round(half - 0.5 - p.imag).astype(np.intp)
    row.setflags(write=False)
    col.setflags(write=False)
    return row, col, size


def _check(fovea: ArrayLike, grid: RetinaGrid) -> NDArray:
    if not isinstance(grid, RetinaGrid):
        raise checks.InputTypeError(f"grid must be a RetinaGrid; got {type(grid).__name__}")
    f = checks.array("fovea", fovea, kinds="biufc", ndim=(1, 2))
    if f.shape[0] != grid.n_fovea:
        raise ValueError(f"fovea samples must have shape (N_f[, C]) = ({grid.n_fovea}[, C]); got {f.shape}")
    return f


def fovea_image(fovea: ArrayLike, grid: RetinaGrid, *, outside: float = 0.0) -> NDArray:
    """The foveal samples as a P x P[ x C] picture (lattice points outside the disc hold ``outside``:
    a finite number, or NaN to mark them)."""
    f = _check(fovea, grid)
    if not (isinstance(outside, (float, np.floating)) and np.isnan(outside)):
        outside = checks.real("outside", outside, hint="or NaN")
    row, col, size = fovea_indices(grid)
    img = np.full((size, size) + f.shape[1:], outside, dtype=np.result_type(f.dtype, float))
    img[row, col] = f
    return img


def fovea_dft(fovea: ArrayLike, grid: RetinaGrid) -> NDArray[np.complex128]:
    """Euclidean 2-D DFT of the foveal picture (zeros outside the disc), shape (P, P[, C])."""
    return np.fft.fft2(fovea_image(fovea, grid), axes=(0, 1))


def fovea_idft(coeffs: ArrayLike, grid: RetinaGrid, *, real: bool = True) -> NDArray:
    """Inverse of ``fovea_dft``: the N_f foveal samples back."""
    real = checks.flag("real", real)
    row, col, size = fovea_indices(grid)
    c = checks.array("coeffs", coeffs, kinds="biufc", ndim=(2, 3))
    if c.shape[:2] != (size, size):
        raise ValueError(f"foveal coefficients must have shape ({size}, {size}[, C]); got {c.shape}")
    img = np.fft.ifft2(c, axes=(0, 1))
    out = img[row, col]
    return out.real if real else out
