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
from conformal import checks
from conformal.dpft import dpft_prechecked
from conformal.remap import point_map_params

__all__ = ["EyeView", "Vision", "REMAP_MODELS", "POOLED_REMAP_DEFAULT", "normalized_error", "model_errors"]

REMAP_MODELS: tuple[str, ...] = ("homography", "mobius", "shift")

#: ``Vision``'s (and the env's) ``pooled_remap`` default: the point prediction. Pooled predictions
#: are closer to the pooled post-saccadic samples (bar scene, +-20 deg horizontal saccades from
#: straight ahead, normalized error of the homography 0.19 -> 0.13, Mobius 0.23 -> 0.18, shift
#: 0.28 -> 0.21; the saccades back unchanged at 0.41-0.45) but cost about 0.1 ms more per env step
#: (three models, two eyes: 1.35-1.4x the point prediction), which puts the default env at
#: 1.25-1.35x the bare MuJoCo loop against a target of 1.3x (``benchmarks/env.py``) instead of
#: 1.21-1.30x; so the env keeps the point prediction unless asked (``benchmarks/remap_pooling.py``).
POOLED_REMAP_DEFAULT = False


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
    if not isinstance(pred, C.RetinaSamples):
        raise checks.InputTypeError(f"pred must be conformal.RetinaSamples; got {type(pred).__name__}")
    if not isinstance(actual, EyeView):
        raise checks.InputTypeError(f"actual must be an EyeView; got {type(actual).__name__}")
    if np.shape(pred.periphery) != actual.periphery.shape or np.shape(pred.fovea) != actual.fovea.shape:
        raise ValueError(
            f"pred and actual must be samples of one retina: periphery {np.shape(pred.periphery)} vs "
            f"{actual.periphery.shape}, fovea {np.shape(pred.fovea)} vs {actual.fovea.shape}"
        )
    for name, a in (("pred", pred.periphery), ("pred", pred.fovea)):
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} contains NaN or infinite samples")
    values = _retina_vector(np.asarray(pred.fovea), np.asarray(pred.periphery))[None, None]
    valid = np.concatenate([pred.fovea_mask, pred.mask.ravel()])[None, None]
    return float(_errors(values, valid, actual.samples[None], actual.valid)[0, 0])


def _errors(values: NDArray, valid: NDArray, actual: NDArray, actual_valid: NDArray) -> NDArray[np.float64]:
    """``normalized_error`` for (E, K) predictions at once (compiled): values (E, K, P, C),
    valid (E, K, P), actual (E, P, C), actual_valid (P,)."""
    out = np.empty(values.shape[:2])
    C.kernels.normalized_errors(values, valid, actual, actual_valid, out)
    return out


_EYE3 = np.eye(3)
_BEHIND = "the shift model needs the new optical axis in front of the old eye (a rotation below 90 degrees)"


def _check_rotations(rotations_eye, shift: bool = False) -> NDArray[np.float64]:
    """A stack of proper rotations (E, 3, 3) float64, checked as ``conformal.check_rotation`` checks
    each one (a float64 (E, 3, 3) array, the head's efference copy, in a few vectorised operations)
    and, with ``shift``, with the new optical axis in front of the old eye (``rotation_faults``)."""
    r = rotations_eye
    if not (type(r) is np.ndarray and r.dtype == np.float64 and r.ndim == 3 and r.shape[1:] == (3, 3)):
        r = np.array([C.check_rotation(x, "rotation_eye") for x in r]).reshape(-1, 3, 3)
    bad, behind = rotation_faults(r, shift)
    if bad.any():
        C.check_rotation(r[int(np.argmax(bad))], "rotation_eye")  # raises with the public message
        raise ValueError("rotation_eye must be a proper rotation matrix (orthogonal, det +1)")
    if behind.any():
        raise ValueError(_BEHIND)
    return r


def rotation_faults(r: NDArray[np.float64], shift: bool) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Masks (...) of the rotations ``r`` (..., 3, 3) that are not proper (orthogonal to 1e-6, det +1; a
    non-finite entry fails) and, with ``shift``, of the proper ones whose new optical axis (second column)
    is not in front of the old eye (the ``shift`` model needs it there): the checks of both visions."""
    err = np.abs(r @ np.swapaxes(r, -1, -2) - _EYE3).max(axis=(-2, -1))  # NaN for non-finite entries
    bad = ~(err <= 1e-6) | (np.linalg.det(np.where(np.isfinite(r), r, 0.0)) < 0)
    return bad, (~bad & (r[..., 1, 1] <= 1e-6)) if shift else np.zeros_like(bad)


def _shift_target(r: NDArray[np.float64]) -> complex:
    """The ``shift`` model's target: the new optical axis (``r``'s second column, in old eye
    coordinates) projected on the old retina plane."""
    axis = r[:, 1]
    if axis[1] <= 1e-6:
        raise ValueError(_BEHIND)
    return (axis[2] + 1j * axis[0]) / axis[1]


@dataclass(frozen=True)
class _Frame:
    """One frame of several eyes as ``Vision`` computed it (internal, for per-step callers): the
    views and, stacked over the eyes, the arrays behind them: samples (E, N_f + M N, C) in retina
    order (each view's ``samples``), periphery (E, M, N, C), coeffs (E, M, N, C), fovea (E, N_f, C)."""

    views: tuple[EyeView, ...]
    samples: NDArray[np.float64]
    periphery: NDArray[np.float64]
    coeffs: NDArray[np.complex128]
    fovea: NDArray[np.float64]


class Vision:
    """Retina + DPFT + efference-copy remapping for both eyes at one image geometry.

    Parameters
    ----------
    image_shape : (H, W) of each eye's image, each in [8, 4096].
    pixels_per_unit : the renderer's f_px (pixels per image-plane unit), in (0, 1e6].
    fovea_deg : foveal radius (the retina's r0 = tan(fovea_deg)), in (0, 30).
    n_sectors : sectors N, an integer in [4, 4096]; default from the paper's rule N = [2 pi r0 K + pi]
        with K the pixel density, rounded up to a multiple of 4 (for the vertical-meridian split).
        The grid must also respect ``conformal.RetinaGrid``'s bounds (at most 2**22 cells, ...).
    grayscale : average the colour channels (C = 1) instead of keeping RGB (C = 3).
    sampling : ``"pool"`` (receptive-field averages) or ``"bilinear"``/``"nearest"``.
    shift_rings : log-radius shift (rings) of the ``shift`` remapping model; > 0 compresses;
        at most M (the number of rings) either way.
    pooled_remap : a bool, the default of the ``predict*`` methods' ``pooled``: average each
        prediction over its receptive field as the pooled retina averages the picture
        (``conformal.RemapPlan``'s ``pooled=True``) instead of the series at the field's centre.
        Default False; see ``POOLED_REMAP_DEFAULT`` for why.

    Images are (H, W, 3): uint8, or floats in [0, 1].
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
        pooled_remap: bool = POOLED_REMAP_DEFAULT,
    ) -> None:
        if isinstance(image_shape, (str, bytes)) or not hasattr(image_shape, "__len__"):
            raise checks.InputTypeError(f"image_shape must be an (H, W) pair; got {image_shape!r}")
        if len(image_shape) != 2:
            raise ValueError(f"image_shape must be an (H, W) pair; got {tuple(image_shape)!r}")
        h, w = (checks.integer(f"image_shape[{i}]", v, 8, 4096) for i, v in enumerate(image_shape))
        pixels_per_unit = checks.real("pixels_per_unit", pixels_per_unit, 0.0, 1e6, lo_open=True)
        fovea_deg = checks.real("fovea_deg", fovea_deg, 0.0, 30.0, lo_open=True, hi_open=True)
        grayscale = checks.flag("grayscale", grayscale)
        self.pooled_remap = checks.flag("pooled_remap", pooled_remap)
        checks.choice("sampling", sampling, ("pool", "bilinear", "nearest"))
        r0 = math.tan(math.radians(fovea_deg))
        rb = min(h, w) / 2 / pixels_per_unit  # inscribed: every cell lies inside the picture
        if r0 >= rb:
            raise ValueError(
                f"fovea_deg = {fovea_deg} covers the whole {h}x{w} picture (r0 = {r0:.3g} >= "
                f"r_b = {rb:.3g}); use a smaller fovea or a larger image"
            )
        if n_sectors is None:
            n_sectors = 4 * math.ceil(round(2 * math.pi * r0 * pixels_per_unit + math.pi) / 4)
        n_sectors = checks.integer("n_sectors", n_sectors, 4, 4096, hint="or None for the paper's rule")
        self.grid = C.RetinaGrid.from_field_of_view(rb, r0, n_sectors)
        self.shift_rings = checks.real(
            "shift_rings",
            shift_rings,
            -self.grid.M,
            self.grid.M,
            hint=f"a log-radius shift within this retina's {self.grid.M} rings",
        )
        self.channels = 1 if grayscale else 3
        self.grayscale = grayscale
        self.retina = C.Retina(self.grid, (h, w, 3), pixels_per_unit, mode=sampling)
        self.image_shape = (h, w)
        self.pixels_per_unit = pixels_per_unit
        self.plan = C.RemapPlan(self.grid)
        self._valid = np.concatenate([self.retina.fovea_mask, self.retina.mask.ravel()])  # EyeView.valid

    # ------------------------------------------------------------------ frames
    def see(self, image: NDArray) -> EyeView:
        """Sample one eye's (H, W, 3) uint8 (or float in [0, 1]) image and take its DPFT."""
        return self.see_eyes((image,))[0]

    def see_eyes(self, images) -> tuple[EyeView, ...]:
        """``see`` for several eyes' images at once (one DPFT call for all of them): each (H, W, 3),
        all uint8 or all floats in [0, 1]."""
        imgs, scale = self._check_images(images)
        return self._frame(self.retina.sample_many(imgs, scale)).views

    def _check_images(self, images) -> tuple[list[NDArray], float]:
        """``see_eyes``' checks: the images as arrays and the scale of their values to [0, 1]."""
        if isinstance(images, np.ndarray) and images.ndim == 3:
            raise ValueError("see_eyes takes a sequence of images (one per eye); use see for one image")
        if isinstance(images, (str, bytes)) or not hasattr(images, "__iter__"):
            raise checks.InputTypeError(f"images must be a sequence of (H, W, 3) images; got {type(images).__name__}")
        imgs = [checks.array("image", im, kinds="uf", finite=False) for im in images]
        if not imgs:
            raise ValueError("see_eyes needs at least one image")
        # scale the few samples, not the whole picture (sampling is linear)
        is_uint8 = [im.dtype == np.uint8 for im in imgs]
        if any(im.dtype.kind == "u" and im.dtype != np.uint8 for im in imgs):
            raise checks.InputTypeError(
                f"images must be uint8 (0..255) or floats in [0, 1]; got {', '.join(str(im.dtype) for im in imgs)}"
            )
        if any(is_uint8) and not all(is_uint8):
            raise ValueError("the eyes' images must all be uint8 or all be float")
        if not is_uint8[0]:
            for im in imgs:
                if im.size and np.isfinite(im).all() and not (im.min() >= -1e-6 and im.max() <= 1 + 1e-6):
                    raise ValueError(
                        f"float images must hold intensities in [0, 1]; got values in "
                        f"[{im.min():.4g}, {im.max():.4g}] (pass uint8 images for 0..255)"
                    )
        return imgs, (1.0 / 255.0 if is_uint8[0] else 1.0)

    def _see_frame(self, images) -> _Frame:
        """``see_eyes`` for a per-step caller (the env), as a ``_Frame`` (the views and the arrays
        behind them). uint8 pictures of this Vision's shape (what ``models.Head.render`` returns)
        go straight to the sampler; anything else takes ``see_eyes``' checks first."""
        shape = self.retina.image_shape
        if images and all(type(im) is np.ndarray and im.dtype == np.uint8 and im.shape == shape for im in images):
            return self._frame(self.retina.sample_prechecked(list(images), 1.0 / 255.0))
        imgs, scale = self._check_images(images)
        return self._frame(self.retina.sample_many(imgs, scale))

    def _frame(self, samples: NDArray[np.float64]) -> _Frame:
        """Views of sampled pictures (E, N_f + M N, 3): channels, periphery, one DPFT for all eyes."""
        if self.grayscale:
            samples = samples.mean(axis=-1, keepdims=True)
        g, n_f = self.grid, self.grid.n_fovea
        n_eyes, chans = samples.shape[0], samples.shape[-1]
        periphery = samples[:, n_f:].reshape(n_eyes, g.M, g.N, chans)
        stacked = periphery.transpose(1, 2, 0, 3).reshape(g.M, g.N, n_eyes * chans)  # eyes side by side as channels
        coeffs = dpft_prechecked(stacked, g).reshape(g.M, g.N, n_eyes, chans)  # (float64 samples of this grid: valid)
        mask, fovea_mask = self.retina.mask, self.retina.fovea_mask
        views = tuple(EyeView(samples[e, :n_f], periphery[e], coeffs[:, :, e], mask, fovea_mask) for e in range(n_eyes))
        return _Frame(views, samples, periphery, coeffs.transpose(2, 0, 1, 3), samples[:, :n_f])

    # ------------------------------------------------------------------ remapping
    def point_map(self, model: str, rotation_eye: NDArray[np.float64]):
        """The point map z_new -> z_old of ``model`` for an eye rotation (new axes in old eye
        coordinates (x1, x2, x3): the efference copy, a proper rotation matrix)."""
        R = C.check_rotation(rotation_eye, "rotation_eye")
        if model == "homography":
            return C.homography_map(R)
        if model == "mobius":
            return C.mobius_map(R)
        if model == "shift":
            return C.target_shift_map(_shift_target(R), self.shift_rings, self.grid.delta)
        checks.choice("model", model, REMAP_MODELS)

    def map_params(self, models: tuple[str, ...], rotations_eye) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """The ``RemapPlan`` description (kinds (K,), params (E, K, 9)) of ``point_map(m, R)`` for the
        ``models`` (names from ``REMAP_MODELS``, not checked) and each eye's rotation R, without
        building the map objects: the same numbers (``tests/test_env_hotpath.py`` compares them).
        The rotations are checked as ``check_rotation`` does (orthogonal to 1e-6, det +1)."""
        r = _check_rotations(rotations_eye, "shift" in models)
        if "shift" in models and abs(self.shift_rings * self.grid.delta) > 40:  # the public constructor's message
            C.target_shift_map(0j, self.shift_rings, self.grid.delta)
        return point_map_params(models, r, self.shift_rings, self.grid.delta)

    def predict(
        self, view: EyeView, model: str, rotation_eye: NDArray[np.float64], *, pooled: bool | None = None
    ) -> C.RetinaSamples:
        """Predicted post-saccadic samples from the pre-saccadic coefficients and the efference copy.

        ``pooled``: average each prediction over its receptive field (``conformal.RemapPlan``'s
        ``pooled``) or take the series at the field's centre; None: this Vision's ``pooled_remap``."""
        return self.predict_models(view, (model,), rotation_eye, pooled=pooled)[model]

    def predict_models(
        self, view: EyeView, models: tuple[str, ...], rotation_eye: NDArray[np.float64], *, pooled: bool | None = None
    ) -> dict[str, C.RetinaSamples]:
        """``predict`` for several remapping models at once."""
        return self.predict_eyes((view,), models, (rotation_eye,), pooled=pooled)[0]

    def predict_eyes(
        self, views: tuple[EyeView, ...], models: tuple[str, ...], rotations_eye, *, pooled: bool | None = None
    ) -> list[dict[str, C.RetinaSamples]]:
        """``predict_models`` for several eyes, each with its own efference copy: [eye]{model: samples}."""
        values, valid = self.predict_arrays(views, models, rotations_eye, pooled=pooled)
        return [dict(zip(models, per_eye)) for per_eye in self.plan.samples(values, valid)]

    def predict_arrays(
        self, views: tuple[EyeView, ...], models: tuple[str, ...], rotations_eye, *, pooled: bool | None = None
    ) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
        """The predictions as arrays in retina order: values (E, K, N_f + M N, C) float32 and
        valid (E, K, N_f + M N), for E eyes and the K ``models`` (``conformal.RemapPlan``).

        The series is evaluated exactly in single precision (~1e-6 relative: far below the
        retina's sampling error). ``pooled`` as in ``predict``."""
        pooled = self.pooled_remap if pooled is None else checks.flag("pooled", pooled)
        views, models, rotations_eye = self._check_predict_args(views, models, rotations_eye)
        maps = [[self.point_map(m, R) for m in models] for R in rotations_eye]
        coeffs = np.stack([v.coeffs for v in views])
        fovea = np.stack([v.fovea for v in views])
        return self.plan(coeffs, fovea, maps, pooled=pooled)

    def _predict_frame(
        self, frame: _Frame, models: tuple[str, ...], rotations_eye
    ) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
        """``predict_arrays(frame.views, models, rotations_eye)`` (``pooled`` as this Vision's
        ``pooled_remap``) for a ``_Frame`` of this Vision (``_see_frame``) and ``models`` already
        checked; the rotations are checked (one per eye)."""
        if len(rotations_eye) != len(frame.views):
            raise ValueError(
                f"rotations_eye must hold one 3x3 rotation per view ({len(frame.views)}); got {len(rotations_eye)}"
            )
        kinds, params = self.map_params(models, rotations_eye)
        return self.plan.evaluate_prechecked(frame.coeffs, frame.fovea, kinds, params, self.pooled_remap)

    def _frame_errors(self, values: NDArray, valid: NDArray, frame: _Frame) -> NDArray[np.float64]:
        """``errors(values, valid, frame.views)`` for ``_predict_frame``'s output and a ``_Frame``."""
        return _errors(values, valid, frame.samples, self._valid)

    def _check_views(self, views) -> tuple[EyeView, ...]:
        if isinstance(views, EyeView) or not isinstance(views, (list, tuple)) or not views:
            raise checks.InputTypeError(f"views must be a non-empty tuple of EyeView (one per eye); got {views!r:.60}")
        g = self.grid
        for v in views:
            if not isinstance(v, EyeView):
                raise checks.InputTypeError(f"views must hold EyeView objects (from see_eyes); got {type(v).__name__}")
            if v.periphery.shape[:2] != (g.M, g.N) or v.coeffs.shape != v.periphery.shape:
                raise ValueError(f"a view does not belong to this Vision's retina ({g.M} rings x {g.N} sectors)")
        if len({v.periphery.shape for v in views}) != 1:
            raise ValueError("the views must all have the same channels")
        return tuple(views)

    def _check_predict_args(self, views, models, rotations_eye):
        views = self._check_views(views)
        if isinstance(models, str) or not isinstance(models, (list, tuple)) or not models:
            raise checks.InputTypeError(
                f"models must be a non-empty tuple of model names from {REMAP_MODELS}; got {models!r:.60}"
            )
        for m in models:
            checks.choice("each model", m, REMAP_MODELS)
        r = checks.array("rotations_eye", rotations_eye, kinds="biuf")
        if r.shape != (len(views), 3, 3):
            raise ValueError(
                f"rotations_eye must hold one 3x3 rotation per view: shape ({len(views)}, 3, 3); got {r.shape}"
            )
        return views, tuple(models), r

    def errors(self, values: NDArray, valid: NDArray, views: tuple[EyeView, ...]) -> NDArray[np.float64]:
        """(E, K) ``normalized_error`` of ``predict_arrays``' output against the actual views."""
        views = self._check_views(views)
        n_points = self.grid.n_fovea + self.grid.M * self.grid.N
        chans = views[0].periphery.shape[2:]
        values = checks.array("values", values, kinds="f", ndim=4)
        if values.shape[0] != len(views) or values.shape[2:] != (n_points,) + chans:
            raise ValueError(
                f"values must be (E, K, P, C) = ({len(views)}, K, {n_points}, {chans[0]}) (predict_arrays' "
                f"output); got {values.shape}"
            )
        valid = checks.array("valid", valid, kinds="b", shape=values.shape[:3])
        actual = np.stack([v.samples for v in views])
        return _errors(values, valid, actual, views[0].valid)


def model_errors(predictions: list[dict[str, C.RetinaSamples]], actual: tuple[EyeView, ...]) -> dict[str, float]:
    """{model: ``normalized_error`` of its prediction, mean over the eyes}: ``predictions`` [eye]{model:
    samples} (``Vision.predict_eyes``) and ``actual`` the views of the same eyes."""
    if (
        not isinstance(predictions, (list, tuple))
        or not predictions
        or not all(isinstance(p, dict) and p for p in predictions)
    ):
        raise checks.InputTypeError(
            "predictions must be a non-empty list (one per eye) of non-empty "
            f"{{model: RetinaSamples}} dicts; got {predictions!r:.60}"
        )
    if not isinstance(actual, (list, tuple)) or len(actual) != len(predictions):
        raise ValueError(
            f"actual must hold one EyeView per eye of predictions ({len(predictions)}); got {actual!r:.60}"
        )
    if any(set(p) != set(predictions[0]) for p in predictions):
        raise ValueError("every eye's predictions must name the same models")
    return {m: float(np.mean([normalized_error(p[m], a) for p, a in zip(predictions, actual)])) for m in predictions[0]}
