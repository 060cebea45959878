"""Hemifields and the cortical map (§2.2, §6.1, §6.4; Figs. 5b, 9f, 10).

The DPFT runs on the full annulus; the vertical-meridian split is applied to its output.
Each hemisphere receives the contralateral hemifield: the left hemisphere the right
hemifield (cos theta > 0), the right hemisphere the left hemifield.

Hemifield arrays are (M, N/2[, C]) in the [ring, sector] convention, sectors running from
the upper vertical meridian (index 0) to the lower one; this needs N divisible by 4 so that
the meridian falls on sector edges. The pasted cortical picture of one eye,
``cortical_map``, is (N/2, 2M[, C]): the right hemisphere on the left half with eccentricity
growing leftwards, the left hemisphere on the right half growing rightwards, the foveal
edges meeting in the middle and the upper meridian on row 0 (cf. Fig. 5b).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import checks
from .grid import RetinaGrid

__all__ = ["hemifields", "cortical_map", "binocular_cortex", "BinocularCortex", "schwartz_map"]


def _check_grid(grid: RetinaGrid) -> RetinaGrid:
    if not isinstance(grid, RetinaGrid):
        raise checks.InputTypeError(f"grid must be a RetinaGrid; got {type(grid).__name__}")
    if grid.N % 4:
        raise ValueError(f"the vertical-meridian split needs N divisible by 4; got N = {grid.N}")
    return grid


def _check(samples: ArrayLike, grid: RetinaGrid, name: str = "samples") -> NDArray:
    """Finite numeric (M, N[, C]) samples on ``grid`` (N divisible by 4)."""
    _check_grid(grid)
    f = checks.array(name, samples, kinds="biufc", ndim=(2, 3))
    if f.shape[:2] != (grid.M, grid.N):
        raise ValueError(f"{name} must have shape (M, N[, C]) = ({grid.M}, {grid.N}[, C]); got {f.shape}")
    return f


def hemifields(samples: ArrayLike, grid: RetinaGrid) -> tuple[NDArray, NDArray]:
    """Split (M, N[, C]) samples into (right_hemifield, left_hemifield), each (M, N/2[, C]).

    Right hemifield: angles from +pi/2 down to -pi/2 (sectors N/4-1, ..., 0, N-1, ..., 3N/4).
    Left hemifield: angles from +pi/2 up to 3 pi/2 (sectors N/4, ..., 3N/4 - 1).
    Both start at the upper vertical meridian.
    """
    f = _check(samples, grid)
    q = grid.N // 4
    right_idx = np.r_[np.arange(q - 1, -1, -1), np.arange(grid.N - 1, 3 * q - 1, -1)]
    left_idx = np.arange(q, 3 * q)
    return f[:, right_idx], f[:, left_idx]


def cortical_map(samples: ArrayLike, grid: RetinaGrid) -> NDArray:
    """Cut-and-paste cortical picture of one eye, (N/2, 2M[, C]) (see the module docstring)."""
    right, left = hemifields(samples, grid)
    rh = np.swapaxes(left, 0, 1)[:, ::-1]  # right hemisphere: left hemifield, periphery on the far left
    lh = np.swapaxes(right, 0, 1)  # left hemisphere: right hemifield, periphery on the far right
    return np.concatenate([rh, lh], axis=1)


@dataclass(frozen=True)
class BinocularCortex:
    """Both hemispheres, each holding the contralateral hemifield of both eyes.

    left_hemisphere / right_hemisphere : (2, M, N/2[, C]); axis 0 is the eye (0 left, 1 right).
    """

    left_hemisphere: NDArray
    right_hemisphere: NDArray

    def __post_init__(self) -> None:
        lh = checks.array("left_hemisphere", self.left_hemisphere, kinds="biufc", ndim=(3, 4))
        rh = checks.array("right_hemisphere", self.right_hemisphere, kinds="biufc", ndim=(3, 4))
        if lh.shape[0] != 2 or lh.shape != rh.shape:
            raise ValueError(
                "left_hemisphere and right_hemisphere must both have shape (2, M, N/2[, C]) "
                f"(axis 0: the eye); got {lh.shape} and {rh.shape}"
            )
        object.__setattr__(self, "left_hemisphere", lh)
        object.__setattr__(self, "right_hemisphere", rh)

    def image(self) -> NDArray:
        """(2 * N/2, 2M[, C]) picture: the left eye's pasted map above the right eye's."""
        rows = []
        for eye in (0, 1):
            rh = np.swapaxes(self.right_hemisphere[eye], 0, 1)[:, ::-1]
            lh = np.swapaxes(self.left_hemisphere[eye], 0, 1)
            rows.append(np.concatenate([rh, lh], axis=1))
        return np.concatenate(rows, axis=0)


def binocular_cortex(left_eye: ArrayLike, right_eye: ArrayLike, grid: RetinaGrid) -> BinocularCortex:
    """Route both eyes' samples to the hemispheres (the optic chiasm of §2.2).

    Both eyes' samples must be finite and of the same shape (M, N[, C])."""
    left = _check(left_eye, grid, "left_eye")
    right = _check(right_eye, grid, "right_eye")
    if left.shape != right.shape:
        raise ValueError(f"left_eye and right_eye must have the same shape; got {left.shape} and {right.shape}")
    lr, ll = hemifields(left, grid)
    rr, rl = hemifields(right, grid)
    return BinocularCortex(left_hemisphere=np.stack([lr, rr]), right_hemisphere=np.stack([ll, rl]))


def schwartz_map(z: ArrayLike, a: float) -> NDArray[np.complex128]:
    """Schwartz's retinotopic map w = ln(z + a) - ln a for the right hemifield (§6.1, Fig. 5a).

    The left hemifield is its mirror image, w = -(ln(-z + a) - ln a), so the two half-maps
    meet at w = 0 along the vertical meridian.
    """
    a = checks.real("a", a, 0.0, None, lo_open=True)
    zz = checks.array("z", z, kinds="biufc").astype(complex)
    right = zz.real >= 0
    with np.errstate(divide="ignore", invalid="ignore"):  # the branch not taken may hit log(0)
        return np.where(right, np.log(zz + a) - np.log(a), -(np.log(-zz + a) - np.log(a)))
