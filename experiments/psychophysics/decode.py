"""Reading the perceived flash position out of a (remapped) retinal/cortical map.

The flash's activity is the flash frame minus a flash-free frame at the same instant, so the
background is 0. The read-out is the activity centroid: each sample's position weighted by its
activity above a fraction of the peak (suppressing the band-limited interpolation's ringing)
times the area its receptive field covers (peripheral cells grow with eccentricity).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

import conformal as C

__all__ = ["activity_centroid", "activity_covariance", "DEFAULT_THRESHOLD"]

#: Activity below this fraction of the peak is ignored by the centroid.
DEFAULT_THRESHOLD = 0.2


def activity_centroid(
    periphery: NDArray[np.float64],
    fovea: NDArray[np.float64],
    grid: C.RetinaGrid,
    *,
    mask: NDArray[np.bool_] | None = None,
    fovea_mask: NDArray[np.bool_] | None = None,
    threshold: float = DEFAULT_THRESHOLD,
) -> complex:
    """Image-plane centroid (complex, relative to the map's centre) of the activity in one map.

    ``periphery`` (M, N[, C]) and ``fovea`` (N_f[, C]) are activities (channels are summed);
    ``mask``/``fovea_mask`` exclude untrusted samples. Returns NaN+NaNj when there is no activity.
    """
    w = _weights(periphery, fovea, grid, mask, fovea_mask, threshold)
    if w is None:
        return complex(np.nan, np.nan)
    wp, wf = w
    total = wp.sum() + wf.sum()
    return complex((wp * grid.points).sum() + (wf * grid.fovea_points).sum()) / total


def _weights(periphery, fovea, grid, mask, fovea_mask, threshold) -> tuple[NDArray, NDArray] | None:
    """Each sample's weight in a map's read-out: its activity (channels summed) above ``threshold`` x
    the peak, times its cell's area; None where the map has no activity."""
    if not 0 <= threshold < 1:
        raise ValueError(f"threshold must be in [0, 1); got {threshold!r}")
    p = np.asarray(periphery, float)
    f = np.asarray(fovea, float)
    if p.ndim == 3:
        p = p.sum(axis=-1)
    if f.ndim == 2:
        f = f.sum(axis=-1)
    if p.shape != (grid.M, grid.N) or f.shape != (grid.n_fovea,):
        raise ValueError(
            f"maps must be (M, N) = ({grid.M}, {grid.N}) and (N_f,) = ({grid.n_fovea},); got {p.shape} and {f.shape}"
        )
    if mask is not None:
        p = np.where(mask, p, 0.0)
    if fovea_mask is not None:
        f = np.where(fovea_mask, f, 0.0)
    peak = max(float(p.max(initial=0.0)), float(f.max(initial=0.0)))
    if not peak > 0:
        return None
    cut = threshold * peak
    wp = np.clip(p - cut, 0.0, None) * grid.cell_areas()[:, None]
    wf = np.clip(f - cut, 0.0, None) * grid.fovea_spacing**2
    return wp, wf


def activity_covariance(
    periphery: NDArray[np.float64],
    fovea: NDArray[np.float64],
    grid: C.RetinaGrid,
    *,
    mask: NDArray[np.bool_] | None = None,
    fovea_mask: NDArray[np.bool_] | None = None,
    threshold: float = DEFAULT_THRESHOLD,
) -> NDArray[np.float64]:
    """The spread of the activity in one map about its centroid: the 2 x 2 covariance of the
    image-plane points (real, imaginary part) under :func:`activity_centroid`'s weights. NaN where
    there is no activity. A disc of radius r gives r^2 / 4 on each axis; a bar of length L, L^2 / 12
    along it."""
    w = _weights(periphery, fovea, grid, mask, fovea_mask, threshold)
    if w is None:
        return np.full((2, 2), np.nan)
    weights = np.concatenate([w[0].ravel(), w[1]])
    z = np.concatenate([np.asarray(grid.points).ravel(), grid.fovea_points])
    total = weights.sum()
    xy = np.stack([z.real, z.imag])
    d = xy - (xy * weights).sum(axis=1, keepdims=True) / total
    return (d * weights) @ d.T / total
