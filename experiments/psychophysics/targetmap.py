"""The target-centred log-polar map: the retina's DPFT series resampled around the saccade target.

§6.5 of the paper remaps the pre-saccadic image into the frame centred on the saccade target
and applies the log-radius shift there. ``TargetCentredMap`` evaluates the DPFT series of one
retinal frame (eq. ``dppcc'``, ``conformal.OffGridEvaluator``) at z_T + z for z on a log-polar
grid centred on the target; points falling in the source retina's fovea take its foveal samples
(bilinear on the foveal lattice). The read-out grid may be finer than the retina
(``oversample``): that is band-limited interpolation of the same samples, no new information,
and it makes the centroid read-out smoother.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

import conformal as C

__all__ = ["TargetCentredMap", "CentredSamples"]


class CentredSamples:
    """A target-centred map: ``periphery`` (M', N'), ``fovea`` (N_f',), validity masks, its grid."""

    def __init__(self, grid: C.RetinaGrid, periphery, fovea, mask, fovea_mask) -> None:
        self.grid, self.periphery, self.fovea, self.mask, self.fovea_mask = grid, periphery, fovea, mask, fovea_mask


class TargetCentredMap:
    """Resample one retina's frames on a log-polar grid centred at any image point.

    retina_grid : the source retina's grid. oversample : integer density factor of the read-out
    grid (sectors x oversample, rings about x oversample, same r0 and outer radius).
    """

    def __init__(self, retina_grid: C.RetinaGrid, oversample: int = 1) -> None:
        if int(oversample) != oversample or not 1 <= oversample <= 8:
            raise ValueError(f"oversample must be an integer in [1, 8]; got {oversample!r}")
        self.source = retina_grid
        if oversample == 1:
            self.grid = retina_grid
        else:
            self.grid = C.RetinaGrid.from_field_of_view(retina_grid.rb, retina_grid.r0, retina_grid.N * int(oversample))

    def sample(self, coeffs: NDArray, fovea: NDArray, centre: complex) -> CentredSamples:
        """The map f(centre + z) for single-channel coeffs (M, N[, 1]) and foveal samples (N_f[, 1])."""
        F = np.asarray(coeffs)
        F = F[..., 0] if F.ndim == 3 else F
        fov = np.asarray(fovea, float)
        fov = fov[..., 0] if fov.ndim == 2 else fov
        c = complex(centre)
        s = C.predict(F, fov, self.source, lambda z: c + z, on=self.grid)
        return CentredSamples(self.grid, s.periphery, s.fovea, s.mask, s.fovea_mask)
