"""A human-readable frame: both eyes' images with the retina grid, and their cortical maps."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

import conformal as C
import models
from conformal import checks

__all__ = ["compose_frame", "grid_overlay"]


@lru_cache(maxsize=8)
def _overlay(grid: C.RetinaGrid, shape: tuple[int, int], ppu: float) -> np.ndarray:
    z = C.pixel_points(shape, ppu)
    k, l = grid.locate(z)
    code = np.where((k >= 0) & (k < grid.M), k * grid.N + l, -1 - (k >= grid.M))
    edge = np.zeros(shape, bool)
    edge[:, 1:] |= code[:, 1:] != code[:, :-1]
    edge[1:, :] |= code[1:, :] != code[:-1, :]
    return edge


def grid_overlay(grid: C.RetinaGrid, shape: tuple[int, int], pixels_per_unit: float) -> np.ndarray:
    """Boolean (H, W) mask of the retina cells' boundaries (rings, sectors, foveal edge)."""
    if not isinstance(grid, C.RetinaGrid):
        raise checks.InputTypeError(f"grid must be a conformal.RetinaGrid; got {type(grid).__name__}")
    if isinstance(shape, (str, bytes)) or not hasattr(shape, "__len__") or len(shape) != 2:
        raise checks.InputTypeError(f"shape must be an (H, W) pair; got {shape!r:.60}")
    h, w = (checks.integer(f"shape[{i}]", v, 1, 16384) for i, v in enumerate(shape))
    ppu = checks.real("pixels_per_unit", pixels_per_unit, 0.0, 1e9, lo_open=True)
    return _overlay(grid, (h, w), ppu)


def _resize_nearest(img: np.ndarray, height: int, width: int) -> np.ndarray:
    rows = (np.arange(height) * img.shape[0] / height).astype(int)
    cols = (np.arange(width) * img.shape[1] / width).astype(int)
    return img[rows][:, cols]


def _to_rgb(a: np.ndarray) -> np.ndarray:
    a = np.clip(a, 0.0, 1.0)
    if a.shape[-1] == 1:
        a = np.repeat(a, 3, axis=-1)
    return (a * 255).astype(np.uint8)


def compose_frame(frame, views, vision) -> np.ndarray:
    """(2H + pad, 2W, 3) uint8: top, left and right eye images with the grid in cyan; bottom,
    each eye's cut-and-paste cortical map (right hemisphere left, left hemisphere right).

    ``frame``: a ``models.StereoFrame``; ``views``: both eyes' ``EyeView`` from ``vision`` (a ``Vision``)."""
    from .vision import EyeView, Vision

    if not isinstance(vision, Vision):
        raise checks.InputTypeError(f"vision must be an envs.Vision; got {type(vision).__name__}")
    if not isinstance(frame, models.StereoFrame):
        raise checks.InputTypeError(f"frame must be a models.StereoFrame; got {type(frame).__name__}")
    if not isinstance(views, (list, tuple)) or len(views) != 2 or not all(isinstance(v, EyeView) for v in views):
        raise checks.InputTypeError("views must be both eyes' EyeView (a pair from Vision.see_eyes)")
    g = vision.grid
    top = []
    for eye in (frame.left, frame.right):
        img = eye.image.copy()
        img[grid_overlay(g, img.shape[:2], eye.pixels_per_unit)] = (0, 200, 200)
        top.append(img)
    h, w = top[0].shape[:2]
    bottom = [_resize_nearest(_to_rgb(C.cortical_map(v.periphery, g)), h // 2, w) for v in views]
    pad = np.full((4, 2 * w, 3), 255, np.uint8)
    return np.concatenate([np.concatenate(top, 1), pad, np.concatenate(bottom, 1)], 0)
