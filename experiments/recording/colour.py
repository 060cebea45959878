"""How the recordings turn numbers into pixels: every logged picture is scaled to its own range with a
documented colour map, so that no panel is nearly black or saturated (:data:`PANEL_SCALES`).

Three scales, each returning a uint8 RGB picture and the (low, high) values that map to the ends of
its colour map (the recordings log them beside the picture as ``value_range``):

- :func:`gain_scaled`: intensities >= 0 (the retina's samples of an eye image; a flash response):
  divided by the picture's maximum, so its brightest value is full scale and 0 stays black; colour
  pictures keep their hue (all channels share the gain), one channel goes through ``cmap``.
- :func:`symmetric_scaled`: signed values (a difference): ``cmap`` (``RdBu_r``: blue < 0 < red) over
  [-m, m] with m the largest magnitude, so 0 is the map's neutral middle.
- :func:`log_scaled`: magnitudes (the DPFT's |F|): ``log10`` from the smallest non-zero magnitude, or
  ``decades`` below the largest if that is higher (below it, the map's lowest colour), to the largest.

An all-zero picture (a flash that fell outside the retina) is shown at its true value, 0, with the
range (0, 0).
"""

from __future__ import annotations

from functools import cache

import numpy as np

__all__ = ["PANEL_SCALES", "gain_scaled", "symmetric_scaled", "log_scaled", "colormap_lut", "contrast"]

#: Entity -> (scale, colour map) of each picture the recordings log ({eye} = left, right).
PANEL_SCALES: dict[str, tuple[str, str]] = {
    "eyes/{eye}/image": ("gain: the rendered image / its maximum", "RGB (hue kept)"),
    "retina/{eye}/fovea": ("gain: / the picture's maximum", "RGB (hue kept), or gray for a grayscale retina"),
    "retina/{eye}/logpolar": ("gain: / the picture's maximum", "RGB (hue kept), or gray for a grayscale retina"),
    "retina/{eye}/flash_response": ("gain: / the picture's maximum (flash minus no flash, >= 0)", "magma"),
    "dpft/{eye}/log_magnitude": ("log10|F| from its smallest value (at most 3 decades down) to its largest", "viridis"),
    "cortex/map": (
        "gain: / the picture's maximum (both hemispheres share it)",
        "RGB (hue kept) or gray; magma for a flash response",
    ),
    "remap/{eye}/predicted": ("gain: / the larger maximum of predicted and actual", "RGB (hue kept)"),
    "remap/{eye}/actual": ("gain: / the larger maximum of predicted and actual", "RGB (hue kept)"),
    "remap/{eye}/difference": ("symmetric: predicted - actual over [-m, m]", "RdBu_r (red: predicted brighter)"),
}
LOG_DECADES = 3.0


@cache
def colormap_lut(name: str) -> np.ndarray:
    """matplotlib's colour map ``name`` as a (256, 3) uint8 table."""
    import matplotlib

    cmap = matplotlib.colormaps[name]
    return (np.asarray(cmap(np.linspace(0.0, 1.0, 256)))[:, :3] * 255.0 + 0.5).astype(np.uint8)


def _finite(a) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    if not np.all(np.isfinite(a)):
        raise ValueError("a picture to log must be finite (NaN or inf found)")
    if a.ndim == 3 and a.shape[-1] == 1:
        a = a[..., 0]
    if a.ndim not in (2, 3) or (a.ndim == 3 and a.shape[-1] not in (3, 4)):
        raise ValueError(f"a picture must be (H, W), (H, W, 1) or (H, W, 3); got shape {a.shape}")
    return a[..., :3] if a.ndim == 3 else a


def _to_pixels(u: np.ndarray, cmap: str) -> np.ndarray:
    """Values in [0, 1] -> uint8: (H, W, 3) kept as RGB, (H, W) through the colour map."""
    q = np.rint(np.clip(u, 0.0, 1.0) * 255.0).astype(np.uint8)
    return q if q.ndim == 3 else colormap_lut(cmap)[q]


def gain_scaled(a, cmap: str = "gray", peak: float | None = None) -> tuple[np.ndarray, tuple[float, float]]:
    """Non-negative values / their maximum (or ``peak``) -> uint8 RGB; ``(0, peak)``."""
    a = _finite(a)
    if np.any(a < 0):
        raise ValueError("gain_scaled takes values >= 0; use symmetric_scaled for signed ones")
    m = float(a.max()) if peak is None else float(peak)
    if m <= 0:
        return _to_pixels(np.zeros_like(a), cmap), (0.0, 0.0)
    return _to_pixels(a / m, cmap), (0.0, m)


def symmetric_scaled(a, cmap: str = "RdBu_r") -> tuple[np.ndarray, tuple[float, float]]:
    """Signed values over [-m, m] (m = the largest magnitude) -> uint8 RGB through ``cmap``;
    a colour picture's channels are averaged first."""
    a = _finite(a)
    if a.ndim == 3:
        a = a.mean(axis=-1)
    m = float(np.abs(a).max())
    if m <= 0:
        return _to_pixels(np.full_like(a, 0.5), cmap), (0.0, 0.0)
    return _to_pixels(0.5 + 0.5 * a / m, cmap), (-m, m)


def log_scaled(mag, cmap: str = "viridis", decades: float = LOG_DECADES) -> tuple[np.ndarray, tuple[float, float]]:
    """Magnitudes >= 0 as ``log10`` over [log10 max - decades, log10 max] -> uint8 RGB through ``cmap``;
    a colour picture's channels are averaged first. The range is returned in log10 units."""
    a = _finite(mag)
    if np.any(a < 0):
        raise ValueError("log_scaled takes magnitudes >= 0")
    if a.ndim == 3:
        a = a.mean(axis=-1)
    m = float(a.max())
    if m <= 0:
        return _to_pixels(np.zeros_like(a), cmap), (0.0, 0.0)
    hi = np.log10(m)
    nz = a[a > 0]
    lo = max(float(np.log10(nz.min())), hi - float(decades))
    with np.errstate(divide="ignore"):
        la = np.log10(a)
    if hi - lo < 1e-12:  # a flat spectrum: one colour, the map's middle
        return _to_pixels(np.full_like(a, 0.5), cmap), (lo, hi)
    return _to_pixels((np.maximum(la, lo) - lo) / (hi - lo), cmap), (lo, hi)


def contrast(pixels) -> tuple[float, float]:
    """(spread, saturated) of a uint8 picture, as the tests judge it: ``spread`` = its brightest
    luminance minus the 0.1th percentile, / 255 (near 0: a flat picture, e.g. nearly black; a few
    bright dots on a dark screen count: they are its content); ``saturated`` = the fraction of pixels
    with a channel at 255."""
    p = np.asarray(pixels)
    if p.dtype != np.uint8:
        raise ValueError(f"contrast takes a uint8 picture; got {p.dtype}")
    lum = p.astype(float).mean(axis=-1) if p.ndim == 3 else p.astype(float)
    lo, hi = np.percentile(lum, 0.1), lum.max()
    sat = float(np.mean(np.any(p == 255, axis=-1) if p.ndim == 3 else p == 255))
    return float(hi - lo) / 255.0, sat
