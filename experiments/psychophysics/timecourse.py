"""The perisaccadic remapping gain time course (the paper's §6.5; Morrone, Ross & Burr 1997).

The gain g(t) is the log-radius shift, in natural-log units, applied around the saccade target
at a flash time t (ms relative to saccade onset): distances from the target shrink by e^{-g}.
g = ln 2 halves them (50 % compression, about the published peak: Morrone et al. 1997; Ross et
al. 1997; Kaiser & Lappe 2004). The time course is an asymmetric Gaussian:

    g(t) = peak_gain * exp(-(t - peak_time_ms)^2 / (2 w^2)),
    w = rise_ms for t < peak_time_ms, decay_ms for t >= peak_time_ms.

With the defaults (peak -10 ms, rise 25 ms, decay 30 ms) compression is 10 % of its peak at
about -64 ms, peaks just before onset, falls to 10 % of its peak by about +54 ms and is below
1e-5 of its peak 150 ms either side of onset.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .bounds import check_real

__all__ = ["RemapTimeCourse"]


@dataclass(frozen=True)
class RemapTimeCourse:
    """Asymmetric-Gaussian gain of the log-radius shift around saccade onset.

    peak_time_ms : time of peak compression relative to saccade onset (ms; < 0 = before onset).
    rise_ms : standard deviation of the rising flank (before the peak): how early remapping starts.
    decay_ms : standard deviation of the falling flank (after the peak): how fast it is gone.
    peak_gain : log-radius shift at the peak, natural-log units (ln 2 ~ 0.693: 50 % compression;
        0 switches remapping off).

    Bounds (``bounds.LIMITS``): peak time within +-1000 ms, flanks 1-1000 ms, gain 0-5.
    """

    peak_time_ms: float = -10.0
    rise_ms: float = 25.0
    decay_ms: float = 30.0
    peak_gain: float = math.log(2.0)

    def __post_init__(self) -> None:
        # bounds: ``bounds.LIMITS`` (TypeError for a non-number, ValueError for NaN/inf/out of range)
        for name in ("peak_time_ms", "rise_ms", "decay_ms", "peak_gain"):
            object.__setattr__(self, name, check_real(name, getattr(self, name)))

    def gain(self, t_ms: ArrayLike) -> NDArray[np.float64] | float:
        """g(t) at flash times ``t_ms`` (ms re saccade onset); a float for a scalar input."""
        t = np.asarray(t_ms)
        if t.dtype.kind not in "iuf":
            raise TypeError(f"t_ms must be real numbers (ms); got dtype {t.dtype}")
        t = t.astype(float)
        if not np.all(np.isfinite(t)):
            raise ValueError("t_ms must be finite (ms re saccade onset)")
        w = np.where(t < self.peak_time_ms, self.rise_ms, self.decay_ms)
        g = self.peak_gain * np.exp(-0.5 * ((t - self.peak_time_ms) / w) ** 2)
        return float(g) if g.ndim == 0 else g

    def compression(self, t_ms: ArrayLike) -> NDArray[np.float64] | float:
        """The compression 1 - e^{-g(t)} the shift alone predicts (the closed-form index)."""
        g = self.gain(t_ms)
        return 1.0 - np.exp(-np.asarray(g)) if np.ndim(g) else 1.0 - math.exp(-g)
