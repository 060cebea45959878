"""Image helpers of the recordings: both eyes' hemisphere as one picture, the retina grid as 2-D
line strips, and an eye image's pinhole matrix (colour scales: :mod:`.colour`)."""

from __future__ import annotations

import numpy as np

import conformal as C


def hemisphere_image(hemisphere: np.ndarray) -> np.ndarray:
    """(2, M, N/2[, C]) [eye, ring, sector] -> (N/2, 2M[, C]) picture: left eye | right eye."""
    h = np.asarray(hemisphere)
    return np.concatenate([np.swapaxes(h[0], 0, 1), np.swapaxes(h[1], 0, 1)], axis=1)


def grid_strips(
    grid: C.RetinaGrid, shape: tuple[int, int], pixels_per_unit: float, n_arc: int = 96
) -> list[np.ndarray]:
    """Retina grid as 2-D line strips in Rerun pixel coordinates (x right, y down, pixel
    centres at +0.5): M + 1 ring circles (incl. the foveal edge r0) and N sector edges."""
    h, w = shape
    f = float(pixels_per_unit)
    radii = grid.r0 * np.exp(grid.delta * np.arange(grid.M + 1))
    t = np.linspace(0.0, 2 * np.pi, n_arc + 1)
    strips = [np.stack([w / 2 + r * f * np.cos(t), h / 2 - r * f * np.sin(t)], -1) for r in radii]
    for a in 2 * np.pi * np.arange(grid.N) / grid.N:
        r = np.array([radii[0], radii[-1]])
        strips.append(np.stack([w / 2 + r * f * np.cos(a), h / 2 - r * f * np.sin(a)], -1))
    return strips


def pinhole_matrix(height: int, width: int, f_px: float) -> np.ndarray:
    """Rerun's ``image_from_camera`` for an eye image: focal length ``f_px`` (= 0.5 H / tan(fovy/2))
    in both axes, principal point at the image centre (W/2, H/2) in Rerun's pixel coordinates
    (pixel centres at +0.5, i.e. ((W-1)/2, (H-1)/2) in ``models.render``'s convention)."""
    return np.array([[f_px, 0.0, width / 2.0], [0.0, f_px, height / 2.0], [0.0, 0.0, 1.0]])
