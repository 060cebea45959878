"""The eyes' visual pipeline: rendered pixels -> retina samples -> DPFT -> remapped predictions.

``Vision`` is built once per image geometry (one ``conformal.Retina`` and grid shared by both
eyes) and then processes frames cheaply. It knows nothing of MuJoCo: it takes images and the
pinhole mapping (``pixels_per_unit``) and eye rotations as plain arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

import conformal as C

__all__ = ["EyeView", "Vision", "REMAP_MODELS", "normalized_error", "model_errors"]

REMAP_MODELS: tuple[str, ...] = ("homography", "mobius", "shift")


@dataclass(frozen=True)
class EyeView:
    """One eye's retinal and cortical representation of one frame.

    fovea (N_f, C) and periphery (M, N, C) samples (float, image values scaled to [0, 1]),
    coeffs (M, N, C) the DPFT of the periphery, mask (M, N) cells inside the picture.
    """

    fovea: NDArray[np.float64]
    periphery: NDArray[np.float64]
    coeffs: NDArray[np.complex128]
    mask: NDArray[np.bool_]
    fovea_mask: NDArray[np.bool_]

    @property
    def samples(self) -> NDArray[np.float64]:
        """All samples in retina order, (N_f + M N, C): the fovea, then the periphery [k, l]."""
        return _retina_vector(self.fovea, self.periphery)

    @property
    def valid(self) -> NDArray[np.bool_]:
        """``fovea_mask`` then ``mask``, in retina order (N_f + M N,)."""
        return np.concatenate([self.fovea_mask, self.mask.ravel()])


def _retina_vector(fovea: NDArray, periphery: NDArray) -> NDArray:
    m, n = periphery.shape[:2]
    c = int(np.prod(periphery.shape[2:]))
    return np.concatenate([fovea.reshape(-1, c), periphery.reshape(m * n, c)])


def normalized_error(pred: C.RetinaSamples, actual: EyeView) -> float:
    """RMS difference over cells valid in both, divided by the RMS contrast of the actual samples.

    0 is a perfect prediction; 1 is as bad as predicting the mean. NaN when no cell is valid.
    """
    values = _retina_vector(np.asarray(pred.fovea), np.asarray(pred.periphery))[None, None]
    valid = np.concatenate([pred.fovea_mask, pred.mask.ravel()])[None, None]
    return float(_errors(values, valid, actual.samples[None], actual.valid)[0, 0])


def _errors(values: NDArray, valid: NDArray, actual: NDArray, actual_valid: NDArray) -> NDArray[np.float64]:
    """``normalized_error`` for (E, K) predictions at once (compiled): values (E, K, P, C),
    valid (E, K, P), actual (E, P, C), actual_valid (P,)."""
    out = np.empty(values.shape[:2])
    C.kernels.normalized_errors(values, valid, actual, actual_valid, out)
    return out


class Vision:
    """Retina + DPFT + efference-copy remapping for both eyes at one image geometry.

    Parameters
    ----------
    image_shape : (H, W) of each eye's image.
    pixels_per_unit : the renderer's f_px (pixels per image-plane unit).
    fovea_deg : foveal radius (the retina's r0 = tan(fovea_deg)).
    n_sectors : sectors N; default from the paper's rule N = [2 pi r0 K + pi] with K the
        pixel density, rounded up to a multiple of 4 (for the vertical-meridian split).
    grayscale : average the colour channels (C = 1) instead of keeping RGB (C = 3).
    sampling : ``"pool"`` (receptive-field averages) or ``"bilinear"``/``"nearest"``.
    shift_rings : log-radius shift (rings) of the ``shift`` remapping model; > 0 compresses.
    """

    def __init__(
        self,
        image_shape: tuple[int, int],
        pixels_per_unit: float,
        *,
        fovea_deg: float = 3.0,
        n_sectors: int | None = None,
        grayscale: bool = False,
        sampling: str = "pool",
        shift_rings: float = 0.0,
    ) -> None:
        h, w = (int(image_shape[0]), int(image_shape[1]))
        if not (math.isfinite(fovea_deg) and 0 < fovea_deg < 30):
            raise ValueError(f"fovea_deg must be in (0, 30); got {fovea_deg!r}")
        r0 = math.tan(math.radians(fovea_deg))
        rb = min(h, w) / 2 / pixels_per_unit  # inscribed: every cell lies inside the picture
        if n_sectors is None:
            n_sectors = 4 * math.ceil(round(2 * math.pi * r0 * pixels_per_unit + math.pi) / 4)
        self.grid = C.RetinaGrid.from_field_of_view(rb, r0, int(n_sectors))
        self.channels = 1 if grayscale else 3
        self.grayscale = bool(grayscale)
        self.retina = C.Retina(self.grid, (h, w, 3), pixels_per_unit, mode=sampling)
        self.image_shape = (h, w)
        self.pixels_per_unit = float(pixels_per_unit)
        self.shift_rings = float(shift_rings)
        self.plan = C.RemapPlan(self.grid)

    # ------------------------------------------------------------------ frames
    def see(self, image: NDArray) -> EyeView:
        """Sample one eye's (H, W, 3) uint8 (or float in [0, 1]) image and take its DPFT."""
        return self.see_eyes((image,))[0]

    def see_eyes(self, images) -> tuple[EyeView, ...]:
        """``see`` for several eyes' images at once (one DPFT call for all of them)."""
        imgs = [np.asarray(im) for im in images]
        if not imgs:
            raise ValueError("see_eyes needs at least one image")
        # scale the few samples, not the whole picture (sampling is linear)
        is_uint8 = [im.dtype == np.uint8 for im in imgs]
        if any(is_uint8) and not all(is_uint8):
            raise ValueError("the eyes' images must all be uint8 or all be float")
        scale = 1.0 / 255.0 if is_uint8[0] else 1.0
        samples = self.retina.sample_many(imgs, scale)  # (E, N_f + M N, 3)
        if self.grayscale:
            samples = samples.mean(axis=-1, keepdims=True)
        g, n_f = self.grid, self.grid.n_fovea
        n_eyes, chans = len(imgs), samples.shape[-1]
        periphery = samples[:, n_f:].reshape(n_eyes, g.M, g.N, chans)
        stacked = periphery.transpose(1, 2, 0, 3).reshape(g.M, g.N, n_eyes * chans)  # eyes side by side as channels
        coeffs = C.dpft(stacked, g).reshape(g.M, g.N, n_eyes, chans)
        mask, fovea_mask = self.retina.mask, self.retina.fovea_mask
        return tuple(EyeView(samples[e, :n_f], periphery[e], coeffs[:, :, e], mask, fovea_mask) for e in range(n_eyes))

    # ------------------------------------------------------------------ remapping
    def point_map(self, model: str, rotation_eye: NDArray[np.float64]):
        """The point map z_new -> z_old of ``model`` for an eye rotation (new axes in old eye
        coordinates (x1, x2, x3): the efference copy)."""
        R = np.asarray(rotation_eye, dtype=float)
        if model == "homography":
            return C.homography_map(R)
        if model == "mobius":
            return C.mobius_map(R)
        if model == "shift":
            axis = R[:, 1]  # the new optical axis in old eye coordinates -> the target
            z_target = (axis[2] + 1j * axis[0]) / axis[1]
            return C.target_shift_map(z_target, self.shift_rings, self.grid.delta)
        raise ValueError(f"unknown remapping model {model!r}; choose one of {', '.join(REMAP_MODELS)}")

    def predict(self, view: EyeView, model: str, rotation_eye: NDArray[np.float64]) -> C.RetinaSamples:
        """Predicted post-saccadic samples from the pre-saccadic coefficients and the efference copy."""
        return self.predict_models(view, (model,), rotation_eye)[model]

    def predict_models(
        self, view: EyeView, models: tuple[str, ...], rotation_eye: NDArray[np.float64]
    ) -> dict[str, C.RetinaSamples]:
        """``predict`` for several remapping models at once."""
        return self.predict_eyes((view,), models, (rotation_eye,))[0]

    def predict_eyes(
        self, views: tuple[EyeView, ...], models: tuple[str, ...], rotations_eye
    ) -> list[dict[str, C.RetinaSamples]]:
        """``predict_models`` for several eyes, each with its own efference copy: [eye]{model: samples}."""
        values, valid = self.predict_arrays(views, models, rotations_eye)
        return [dict(zip(models, per_eye)) for per_eye in self.plan.samples(values, valid)]

    def predict_arrays(
        self, views: tuple[EyeView, ...], models: tuple[str, ...], rotations_eye
    ) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
        """The predictions as arrays in retina order: values (E, K, N_f + M N, C) float32 and
        valid (E, K, N_f + M N), for E eyes and the K ``models`` (``conformal.RemapPlan``).

        The series is evaluated exactly in single precision (~1e-6 relative: far below the
        retina's sampling error)."""
        maps = [[self.point_map(m, R) for m in models] for R in rotations_eye]
        coeffs = np.stack([v.coeffs for v in views])
        fovea = np.stack([v.fovea for v in views])
        return self.plan(coeffs, fovea, maps)

    def errors(self, values: NDArray, valid: NDArray, views: tuple[EyeView, ...]) -> NDArray[np.float64]:
        """(E, K) ``normalized_error`` of ``predict_arrays``' output against the actual views."""
        actual = np.stack([v.samples for v in views])
        return _errors(values, valid, actual, views[0].valid)


def model_errors(
    predictions: list[dict[str, C.RetinaSamples]], actual: tuple[EyeView, ...]
) -> dict[str, float]:
    """{model: ``normalized_error`` of its prediction, mean over the eyes}."""
    return {m: float(np.mean([normalized_error(p[m], a) for p, a in zip(predictions, actual)]))
            for m in predictions[0]}
