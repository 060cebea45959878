"""The log-radius shift of §6.5: f(u_k + j delta, theta_l) by the Fourier shift property.

A shift by j rings (integer or fractional) multiplies the u-spectrum of e^u f by
e^{i 2 pi m j / L} (signed m) and re-weights by e^{-(u_k + j delta)}. Positive j brings
content from larger radii inwards, f'(z) = f(e^{j delta} z): the compression of §6.5.

``wrap=True`` is the paper's circular version (L = M, the series of e^u f): content pushed
through the inner edge re-enters from the periphery, the artefact the paper reports in
§6.5.1. The default does not wrap: it shifts the series of f extended evenly about both
edges of the annulus (L = 2M, no jump at the seams, so fractional shifts do not ring), and
rings whose source lies outside the sampled annulus become 0.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import checks
from .dpft import _check_samples, _expand
from .grid import RetinaGrid

__all__ = ["log_radius_shift"]


def log_radius_shift(samples: ArrayLike, grid: RetinaGrid, shift: float, *, wrap: bool = False) -> NDArray[np.float64]:
    """Peripheral samples of f(e^{shift * delta} z): a shift by ``shift`` rings in log-radius.

    ``samples`` is (M, N[, C]); the result has the same shape. Integer shifts move rings
    exactly; with ``wrap=True`` the rings pushed through the inner edge re-enter at the outer
    edge scaled by e^{-T} (the series is periodic in e^u f, so f is quasi-periodic).
    Fractional shifts are band-limited interpolation in u. ``shift`` is any finite number of rings
    (beyond M + 1/2 either way the non-wrapping result is 0); with ``wrap=True`` at most 4 M either
    way (the wrapped copies are scaled by e^{-shift delta}, which must stay within range).
    """
    f = _check_samples(samples, grid, "samples")
    wrap = checks.flag("wrap", wrap)
    m = grid.M
    if wrap:
        j = checks.real("shift", shift, -4 * m, 4 * m, hint="in rings, with wrap=True")
    else:
        j = checks.real("shift", shift, hint="in rings")
        if abs(j) >= m + 0.5:  # every source ring lies outside the sampled annulus
            return np.zeros(f.shape)
    if wrap:
        length = m
        u = grid.u
        seq = _expand(np.exp(u), f.ndim) * f
    else:
        length = 2 * m
        seq = np.concatenate([f, f[::-1]], axis=0)
    spec = np.fft.fft(seq, axis=0)
    freq = np.fft.fftfreq(length, 1.0 / length)
    if length % 2 == 0:
        freq[length // 2] = 0.0  # split the Nyquist term symmetrically: keeps real data real
        spec[length // 2] *= math.cos(math.pi * j)
    spec *= _expand(np.exp(2j * math.pi * freq * j / length), f.ndim)
    out = np.fft.ifft(spec, axis=0).real[:m]
    if wrap:
        return out * _expand(np.exp(-(grid.u + j * grid.delta)), f.ndim)
    src = np.arange(m) + j
    out[(src < -0.5) | (src > m - 0.5)] = 0.0
    return out
