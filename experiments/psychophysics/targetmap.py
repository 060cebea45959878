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
        self._z = np.concatenate([self.grid.fovea_points, self.grid.points.ravel()])

    def _fovea_lookup(self, fovea: NDArray, w: NDArray[np.complex128]) -> NDArray:
        g = self.source
        img = C.fovea_image(fovea, g)
        size = img.shape[0]
        col = w.real / g.fovea_spacing + size / 2 - 0.5
        row = size / 2 - 0.5 - w.imag / g.fovea_spacing
        c0 = np.clip(np.floor(col).astype(int), 0, size - 2)
        r0 = np.clip(np.floor(row).astype(int), 0, size - 2)
        fc, fr = np.clip(col - c0, 0, 1), np.clip(row - r0, 0, 1)
        return (img[r0, c0] * (1 - fr) * (1 - fc) + img[r0, c0 + 1] * (1 - fr) * fc
                + img[r0 + 1, c0] * fr * (1 - fc) + img[r0 + 1, c0 + 1] * fr * fc)

    def sample(self, coeffs: NDArray, fovea: NDArray, centre: complex) -> CentredSamples:
        """The map f(centre + z) for single-channel coeffs (M, N[, 1]) and foveal samples (N_f[, 1])."""
        F = np.asarray(coeffs)
        F = F[..., 0] if F.ndim == 3 else F
        fov = np.asarray(fovea, float)
        fov = fov[..., 0] if fov.ndim == 2 else fov
        g = self.source
        w = complex(centre) + self._z
        r = np.abs(w)
        in_fovea = r < g.r0
        in_periph = (r >= g.r0) & (r < g.ring_edges[-1])
        out = np.zeros(len(w))
        if np.any(in_periph):
            out[in_periph] = C.OffGridEvaluator(g, w[in_periph])(F)
        if np.any(in_fovea):
            out[in_fovea] = self._fovea_lookup(fov, w[in_fovea])
        valid = in_fovea | in_periph
        out[~valid] = 0.0
        nf = self.grid.n_fovea
        shape = (self.grid.M, self.grid.N)
        return CentredSamples(self.grid, out[nf:].reshape(shape), out[:nf], valid[nf:].reshape(shape), valid[:nf])
