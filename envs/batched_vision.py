"""``TorchVision``: the per-frame visual pipeline of ``envs.vision.Vision`` for B worlds x E eyes at once, in torch.

The batched env (``envs.batched_env``) renders every world's eyes on a device; this module takes
those pictures through the same steps as ``Vision`` does for one world, all worlds and eyes in one
set of tensor operations on the device ("cuda" or "cpu"): ``see`` (receptive-field pooling,
grayscale, the DPFT of the periphery, eqs. ``lpdft``/``dpft``), ``predict`` (every model's point
prediction, the mirror series of eq. ``dppcc'`` through ``conformal.TorchRemapPlan``), ``errors``
(their normalized RMS errors) and ``cortical`` (the env's observation, with
``conformal.binocular_cortex``'s hemifield routing).

What depends only on the grid is built once in float64 from the CPU ``Vision`` and kept on the
device in float32; the per-frame work runs in float32, so the numbers are the CPU path's up to
float32 rounding (``tests/test_batched_vision.py`` measures the differences). ``predict`` processes
the worlds in chunks whose tables stay under ``chunk_bytes``.

Each step's CPU counterpart, the precision and the memory in full: docs/batched.md ("Batched env",
section "The vision: TorchVision").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from conformal import checks, hemifields
from conformal.maps import KIND_MOBIUS, KIND_PROJECTIVE  # RemapPlan's map kinds: a homography, a Mobius map
from conformal.remap import point_map_params

from .vision import REMAP_MODELS, Vision, rotation_faults

try:
    import torch
except ImportError:  # pragma: no cover - the module is only imported with torch (the gpu extra)
    raise ImportError(
        'envs.batched_vision needs torch: pip install -e ".[gpu]" (torch\'s CPU build serves without a GPU)'
    ) from None

from conformal.torch_plan import TorchRemapPlan  # noqa: E402  (after torch's check)
from conformal.torch_plan import ieee_matmul as _ieee_matmul

__all__ = ["TorchVision", "TorchFrame", "KIND_PROJECTIVE", "KIND_MOBIUS"]

_DEFAULT_CHUNK_BYTES = 1 << 30


@dataclass(frozen=True)
class TorchFrame:
    """One frame of B worlds x E eyes as ``TorchVision.see`` computed it (cf. ``envs.vision._Frame``).

    samples (B, E, P, C) float32 in retina order (the N_f foveal samples, then the periphery [k, l]
    row-major; P = N_f + M N), periphery (B, E, M, N, C) and fovea (B, E, N_f, C) views of it, and
    coeffs (B, E, M, N, C) complex64: the DPFT of the periphery (``conformal.dpft.dpft_prechecked``)."""

    samples: torch.Tensor
    periphery: torch.Tensor
    fovea: torch.Tensor
    coeffs: torch.Tensor

    @property
    def batch_shape(self) -> tuple[int, int]:
        """(B, E)."""
        b, e = self.samples.shape[:2]
        return (b, e)


class TorchVision:
    """Vision's per-frame pipeline for B worlds x E eyes at once, in torch (built from a CPU ``Vision``).

    Parameters
    ----------
    vision : the CPU ``envs.vision.Vision`` whose grid, retina, channels and ``shift_rings`` this
        replicates (its ``pooled_remap`` must be False: only the point prediction is ported).
    device : a torch device or its name (``"cuda"``, ``"cuda:1"``, ``"cpu"``).
    chunk_bytes : the most bytes one of ``predict``'s per-chunk float32 tables may take (default
        1 GiB); the worlds are processed in as many chunks as that needs.

    Attributes ``grid``, ``channels``, ``n_points`` (P), ``image_shape`` (H, W) and ``valid`` (P,) bool
    on the device (``EyeView.valid``: the cells inside the picture) describe the retina.

    On CUDA, ``predict``'s matrix products run at full float32 precision even where the caller enabled
    TF32 (``torch.backends.cuda.matmul.fp32_precision``, ``allow_tf32`` or
    ``torch.set_float32_matmul_precision("high")``):
    TF32's 10-bit mantissa would put ~1e-3 relative errors into the series; the caller's setting is
    restored after each call.
    """

    def __init__(
        self, vision: Vision, device: str | torch.device = "cpu", *, chunk_bytes: int = _DEFAULT_CHUNK_BYTES
    ) -> None:
        if not isinstance(vision, Vision):
            raise checks.InputTypeError(f"vision must be an envs.vision.Vision; got {type(vision).__name__}")
        if vision.pooled_remap:
            raise ValueError("TorchVision ports the point prediction only; build the Vision with pooled_remap=False")
        self.device = _resolve_device(device)
        self.chunk_bytes = checks.integer("chunk_bytes", chunk_bytes, 1 << 16, None)
        self.vision = vision
        g = self.grid = vision.grid
        self.channels = vision.channels
        self.grayscale = vision.grayscale
        self.shift_rings = float(vision.shift_rings)
        self.image_shape = tuple(vision.image_shape)
        self.n_points = g.n_fovea + g.M * g.N
        dev, f32 = self.device, torch.float32
        retina = vision.retina

        # --- sampling (Retina.sample_prechecked): the receptive-field operator, rows normalised to averages
        # as CSR arrays: each field's pixels (sorted) and weights, and the rows' offsets. The product is a
        # gather and a segment sum (each field's pixels added in index order, one thread per field and
        # column), not cuSPARSE's SpMM, whose default algorithm on CUDA adds in an order that changes from
        # call to call: that broke "same seed, same observations" and a world's independence of the others
        op = retina.operator.tocsr()
        op.sort_indices()
        self._pool_pixels = torch.as_tensor(op.indices.astype(np.int64), device=dev)
        self._pool_weights = torch.as_tensor(op.data, dtype=f32, device=dev).view(-1, 1)
        self._pool_offsets = torch.as_tensor(op.indptr.astype(np.int64), device=dev)
        self._fill = float(retina.fill)
        self._empty = torch.as_tensor(np.flatnonzero(retina.empty), device=dev) if self._fill != 0.0 else None
        self.valid = torch.as_tensor(np.array(vision._valid), device=dev)

        # --- the DPFT and the point prediction's tables (conformal's torch series)
        self.plan = TorchRemapPlan(g, self.device)

        # --- the cortex (cortex.hemifields): right and left hemifield sectors from the upper meridian
        self._hemifields = None
        if g.N % 4 == 0:
            right, left = hemifields(np.tile(np.arange(g.N), (g.M, 1)), g)  # the sectors' indices, in order
            self._hemifields = (torch.as_tensor(right[0], device=dev), torch.as_tensor(left[0], device=dev))

    # ------------------------------------------------------------------ frames
    def see(self, images: torch.Tensor, *, check_range: bool = True) -> TorchFrame:
        """Sample every world's eyes' pictures on the retina and take the DPFT (``Vision._see_frame``).

        images: (B, E, H, W, 3) on this device, uint8 (0..255) or floating point in [0, 1] (float16,
        bfloat16, float64 are taken as float32), (H, W) this Vision's ``image_shape``, row 0 the top of
        the picture (``models.Head.render``'s images). ``check_range`` (floating images only): check
        the values lie in [0, 1] (to 1e-6, as ``Vision`` does; one reduction and a device sync).
        """
        x = self._check_images(images, check_range)
        b, e = x.shape[:2]
        h, w = self.image_shape
        scale = 1.0 / 255.0 if x.dtype == torch.uint8 else 1.0
        # the pictures as the columns of one dense matrix (H W, B E C'), converted and transposed in one copy;
        # in grayscale the channels are summed first (the pooling is linear: the mean of the pooled channels)
        view = x.permute(2, 3, 0, 1, 4)
        if self.grayscale:
            cols = torch.empty((h, w, b, e), dtype=torch.float32, device=self.device)
            torch.sum(view, dim=-1, dtype=torch.float32, out=cols)
            cols = cols.view(h * w, b * e)
            scale /= 3.0
        else:
            cols = torch.empty((h, w, b, e, 3), dtype=torch.float32, device=self.device)
            cols.copy_(view)
            cols = cols.view(h * w, b * e * 3)
        picked = cols.index_select(0, self._pool_pixels).mul_(self._pool_weights)  # (nnz, B E C)
        pooled = torch.segment_reduce(
            picked, "sum", offsets=self._pool_offsets, axis=0, unsafe=True, initial=0.0
        )  # (P, B E C)
        del picked
        samples = pooled.view(self.n_points, b, e, self.channels).permute(1, 2, 0, 3).contiguous()
        samples.mul_(scale)
        if self._empty is not None:  # cells with no pixel (Retina's fill; Vision's default fill is 0)
            samples[:, :, self._empty] = self._fill
        return self._frame(samples)

    def see_samples(self, samples: torch.Tensor) -> TorchFrame:
        """A frame from retina samples already taken (``Vision._frame``): samples (B, E, P, 3) floats in
        [0, 1] (not checked) on this device in retina order (e.g. rendered along the receptive fields'
        rays: ``WarpHeads.render_retina``); in grayscale the channels are averaged."""
        s = self._float_tensor(
            "samples",
            samples,
            "(B, E, P, 3)",
            (self.n_points, 3),
            " with B, E >= 1",
            lambda t: t.dim() == 4 and t.shape[2:] == (self.n_points, 3) and 0 not in t.shape[:2],
        )
        if self.grayscale:
            s = s.mean(dim=-1, keepdim=True)
        return self._frame(s.contiguous())

    def _frame(self, samples: torch.Tensor) -> TorchFrame:
        """``Vision._frame``: the periphery and fovea views of (B, E, P, C) float32 samples and the DPFT of
        the periphery (``dpft.dpft_prechecked``: the FFT over (ring, sector) of w e^{u_k} f, times the phase)."""
        g, n_f = self.grid, self.grid.n_fovea
        b, e, _, c = samples.shape
        periphery = samples[:, :, n_f:].view(b, e, g.M, g.N, c)
        return TorchFrame(
            samples=samples, periphery=periphery, fovea=samples[:, :, :n_f], coeffs=self.plan.dpft(periphery)
        )

    def _float_tensor(self, name: str, x, form: str, tail: tuple, extra: str, shape_ok) -> torch.Tensor:
        """``x`` as float32 after checking it is a floating-point tensor on this device of shape ``form``
        (``shape_ok``), its trailing sizes ``tail``; errors name ``name``."""
        if not isinstance(x, torch.Tensor):
            raise checks.InputTypeError(f"{name} must be a torch.Tensor {form}; got {type(x).__name__}")
        if not shape_ok(x):
            want = ", ".join(str(d) for d in tail)
            raise ValueError(f"{name} must be {form} = (B, E, {want}){extra}; got {tuple(x.shape)}")
        if not x.is_floating_point():
            raise checks.InputTypeError(f"{name} must be floating point; got {x.dtype}")
        self._check_device(name, x)
        return x.to(torch.float32)

    # ------------------------------------------------------------------ remapping
    def map_params(self, models: tuple[str, ...], rotations_eye: torch.Tensor) -> tuple[tuple[int, ...], torch.Tensor]:
        """The ``RemapPlan`` description of each model's point map for each world's eyes' rotations,
        ``Vision.map_params`` vectorised over (B, E): kinds (K,) (``KIND_PROJECTIVE`` for the homography,
        else ``KIND_MOBIUS``) and params (B, E, K, 9) float64 on the device:

        ``conformal.remap.point_map_params``'s numbers, computed on the host (the rotations are checked on
        the device first):

        rotations_eye (B, E, 3, 3) floating point on this device (float32 rotations are taken in float64),
        each a proper rotation (orthogonal to 1e-6, det +1: ``conformal.check_rotation``); with ``shift``,
        each new optical axis must lie in front of the old eye (a rotation below 90 degrees). A
        ValueError names the first world and eye that fails (one device sync)."""
        models = self._check_models(models)
        r = self._check_rotation_tensor(rotations_eye)
        return self._map_params(models, r)

    def _map_params(self, models: tuple[str, ...], r: torch.Tensor) -> tuple[tuple[int, ...], torch.Tensor]:
        rot = r.to(torch.float64).cpu().numpy()  # the one sync
        bad, behind = rotation_faults(rot, "shift" in models)
        if bad.any():
            w, k = (int(i) for i in np.argwhere(bad)[0])
            raise ValueError(
                f"rotations_eye[{w}, {k}] (world {w}, eye {k}) must be a proper rotation matrix (orthogonal, det +1)"
            )
        if behind.any():
            w, k = (int(i) for i in np.argwhere(behind)[0])
            raise ValueError(
                f"world {w}, eye {k}: the shift model needs the new optical axis in front of the old eye "
                "(a rotation below 90 degrees)"
            )
        kinds, params = point_map_params(models, rot, self.shift_rings, self.grid.delta)  # conformal's numbers
        return tuple(int(k) for k in kinds), torch.as_tensor(params, device=r.device)

    def predict(
        self, frame: TorchFrame, rotations_eye: torch.Tensor, models: tuple[str, ...]
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """The remapping models' point predictions of the post-saccadic retina of every world's eyes from
        the frame's pre-saccadic coefficients and foveal samples and the efference copies
        (``Vision._predict_frame`` with ``pooled=False``: ``RemapPlan._evaluate``, point prediction).

        rotations_eye (B, E, 3, 3) floating point on this device (what the env passes as
        ``plan.efference_copy_eye``, per world), ``models`` names from ``REMAP_MODELS``. Returns values
        (B, E, K, P, C) float32 in retina order and valid (B, E, K, P) bool; invalid points (the source
        beyond r_b, behind the eye, or at a pole) hold 0. Each point z is mapped to w (``kernels.map_points``):
        |w| < r0 takes the bilinear interpolant of the foveal lattice (``remap._fovea_lookup``),
        r0 <= |w| < r_b the mirror series of eq. ``dppcc'`` at w (``kernels.tabulate_angles``: cos/sin of
        n y for the angular frequencies; a matrix product with the series coefficients; ``contract_rings``:
        the sum over the ring frequencies, cos(m t))."""
        self._check_frame(frame)
        models = self._check_models(models)
        r = self._check_rotation_tensor(rotations_eye, frame.batch_shape)
        kinds, params = self._map_params(models, r)
        b, e = frame.batch_shape
        c = frame.samples.shape[-1]
        g = self.grid
        n_pts, n_maps = self.n_points, len(models)
        be = b * e
        coeffs = frame.coeffs.reshape(be, g.M, g.N, c)
        fovea = frame.fovea.reshape(be, g.n_fovea, c)
        params = params.to(torch.float32).reshape(be, n_maps, 9)
        values = torch.empty((be, n_maps, n_pts, c), dtype=torch.float32, device=self.device)
        valid = torch.empty((be, n_maps, n_pts), dtype=torch.bool, device=self.device)
        chunk = max(1, min(be, self.chunk_bytes // self.plan.table_bytes(n_maps, c)))
        with _ieee_matmul(self.device):
            for s in range(0, be, chunk):
                sl = slice(s, min(be, s + chunk))
                values[sl], valid[sl] = self.plan.evaluate_prechecked(coeffs[sl], fovea[sl], kinds, params[sl])
        return values.view(b, e, n_maps, n_pts, c), valid.view(b, e, n_maps, n_pts)

    def errors(self, values: torch.Tensor, valid: torch.Tensor, frame: TorchFrame) -> torch.Tensor:
        """(B, E, K) float32: each prediction's normalized RMS error against the frame's samples
        (``Vision._frame_errors`` -> ``kernels.normalized_errors``): RMS(pred - actual) / RMS(actual -
        mean actual) over the points valid in both (the prediction's ``valid`` and the retina's
        ``valid``), the contrast floored at 1e-12; NaN where no point is valid."""
        self._check_frame(frame)
        b, e = frame.batch_shape
        c = frame.samples.shape[-1]
        if not isinstance(values, torch.Tensor) or not isinstance(valid, torch.Tensor):
            raise checks.InputTypeError(
                f"values and valid must be torch tensors (predict's output); got "
                f"{type(values).__name__} and {type(valid).__name__}"
            )
        if values.dim() != 5 or values.shape[:2] != (b, e) or values.shape[3:] != (self.n_points, c):
            raise ValueError(
                f"values must be (B, E, K, P, C) = ({b}, {e}, K, {self.n_points}, {c}) "
                "(predict's output); "
                f"got {tuple(values.shape)}"
            )
        if values.dtype != torch.float32:
            raise checks.InputTypeError(f"values must be float32; got {values.dtype}")
        if valid.dtype != torch.bool or valid.shape != values.shape[:4]:
            raise ValueError(
                f"valid must be bool of shape {tuple(values.shape[:4])}; got {valid.dtype} {tuple(valid.shape)}"
            )
        self._check_device("values", values)
        self._check_device("valid", valid)
        actual = frame.samples.unsqueeze(2)  # (B, E, 1, P, C)
        mask = (valid & self.valid).unsqueeze(-1).to(torch.float32)  # (B, E, K, P, 1)
        count = mask.sum(dim=(-2, -1)) * c  # n C
        mean = (actual * mask).sum(dim=(-2, -1)) / count
        diff = (values - actual).square_().mul_(mask).sum(dim=(-2, -1))
        contrast = (actual - mean[..., None, None]).square_().mul_(mask).sum(dim=(-2, -1))
        out = torch.sqrt(diff / count) / torch.sqrt(contrast / count).clamp(min=1e-12)
        return torch.where(count > 0, out, torch.nan)

    def cortical(self, periphery: torch.Tensor, cortex: str) -> torch.Tensor:
        """The ``cortical`` observation of peripheral samples (``BinocularSaccadeEnv._cortical``), clipped to
        [0, 1], float32: ``"eyes"``: (B, E, M, N, C) as given; ``"hemispheres"`` (E = 2, N divisible by 4):
        (B, 2, 2, M, N/2, C) [world, hemisphere (left, right), eye (left, right), ring, sector-in-hemifield],
        each hemisphere the contralateral hemifield of both eyes (``conformal.binocular_cortex``)."""
        checks.choice("cortex", cortex, ("eyes", "hemispheres"))
        g = self.grid
        p = self._float_tensor(
            "periphery",
            periphery,
            "(B, E, M, N, C)",
            (g.M, g.N, "C"),
            "",
            lambda t: t.dim() == 5 and t.shape[2:4] == (g.M, g.N),
        )
        if cortex == "eyes":
            return p.clamp(0.0, 1.0)
        if self._hemifields is None:
            raise ValueError(f"cortex='hemispheres' needs N divisible by 4; got N = {g.N}")
        if periphery.shape[1] != 2:
            raise ValueError(f"cortex='hemispheres' needs two eyes (E = 2); got E = {periphery.shape[1]}")
        right, left = self._hemifields
        # left hemisphere: both eyes' right hemifields; right hemisphere: both eyes' left hemifields
        return torch.stack([p[:, :, :, right], p[:, :, :, left]], dim=1).clamp_(0.0, 1.0)

    # ------------------------------------------------------------------ checks
    def _check_device(self, name: str, t: torch.Tensor) -> None:
        if not _same_device(t.device, self.device):
            raise ValueError(
                f"{name} is on {t.device}, but this TorchVision works on {self.device}; move it "
                f"there first (.to({str(self.device)!r}))"
            )

    def _check_images(self, images, check_range: bool) -> torch.Tensor:
        h, w = self.image_shape
        if not isinstance(images, torch.Tensor):
            raise checks.InputTypeError(
                f"images must be a torch.Tensor (B, E, {h}, {w}, 3); got {type(images).__name__}"
            )
        check_range = checks.flag("check_range", check_range)
        if images.dim() != 5 or images.shape[2:] != (h, w, 3) or 0 in images.shape[:2]:
            raise ValueError(
                f"images must be (B, E, H, W, 3) = (B, E, {h}, {w}, 3) with B, E >= 1 (this Vision's "
                f"image shape); got {tuple(images.shape)}"
            )
        if images.dtype != torch.uint8 and not images.is_floating_point():
            raise checks.InputTypeError(
                f"images must be uint8 (0..255) or floating point in [0, 1]; got {images.dtype}"
            )
        self._check_device("images", images)
        if images.dtype == torch.uint8:
            return images
        if check_range:  # as Vision._check_images: a picture with NaN is not range-checked
            lo, hi = torch.aminmax(images.reshape(images.shape[0], -1), dim=1)
            bad = (lo < -1e-6) | (hi > 1 + 1e-6)
            stats = torch.stack([bad.to(lo.dtype), lo, hi]).cpu()
            if stats[0].any():
                i = int(torch.nonzero(stats[0])[0])
                raise ValueError(
                    f"float images must hold intensities in [0, 1]; world {i} has values in "
                    f"[{float(stats[1, i]):.4g}, {float(stats[2, i]):.4g}] (pass uint8 images for 0..255)"
                )
        return images

    def _check_frame(self, frame) -> None:
        if not isinstance(frame, TorchFrame):
            raise checks.InputTypeError(
                f"frame must be a TorchFrame (from TorchVision.see); got {type(frame).__name__}"
            )
        g = self.grid
        if frame.coeffs.shape[2:4] != (g.M, g.N) or frame.samples.shape[2] != self.n_points:
            raise ValueError(
                f"frame does not belong to this TorchVision's retina ({g.M} rings x {g.N} sectors, "
                f"{self.n_points} points)"
            )
        self._check_device("frame", frame.samples)

    def _check_models(self, models) -> tuple[str, ...]:
        if isinstance(models, str) or not isinstance(models, (list, tuple)) or not models:
            raise checks.InputTypeError(
                f"models must be a non-empty tuple of model names from {REMAP_MODELS}; got {models!r:.60}"
            )
        for m in models:
            checks.choice("each model", m, REMAP_MODELS)
        if "shift" in models and abs(self.shift_rings * self.grid.delta) > 40:  # target_shift_map's message
            raise ValueError(
                f"shift * delta = {self.shift_rings * self.grid.delta:.4g}: the scale e^(shift delta) "
                "must lie within e^(+-40)"
            )
        return tuple(models)

    def _check_rotation_tensor(self, rotations_eye, batch: tuple[int, int] | None = None) -> torch.Tensor:
        if not isinstance(rotations_eye, torch.Tensor):
            raise checks.InputTypeError(
                f"rotations_eye must be a torch.Tensor (B, E, 3, 3); got {type(rotations_eye).__name__}"
            )
        if not rotations_eye.is_floating_point():
            raise checks.InputTypeError(f"rotations_eye must be floating point; got {rotations_eye.dtype}")
        want = (
            "(B, E, 3, 3)" if batch is None else f"(B, E, 3, 3) = ({batch[0]}, {batch[1]}, 3, 3) (one per world's eye)"
        )
        if (
            rotations_eye.dim() != 4
            or rotations_eye.shape[2:] != (3, 3)
            or 0 in rotations_eye.shape[:2]
            or (batch is not None and tuple(rotations_eye.shape[:2]) != batch)
        ):
            raise ValueError(f"rotations_eye must be {want}; got {tuple(rotations_eye.shape)}")
        self._check_device("rotations_eye", rotations_eye)
        return rotations_eye


def _resolve_device(device) -> torch.device:
    """A torch.device with its CUDA index filled in (so tensors' devices compare equal)."""
    if isinstance(device, str):
        try:
            dev = torch.device(device)
        except RuntimeError:
            raise ValueError(f"device must be 'cpu', 'cuda' or 'cuda:<index>'; got {device!r}") from None
    elif isinstance(device, torch.device):
        dev = device
    else:
        raise checks.InputTypeError(f"device must be a string or a torch.device; got {type(device).__name__}")
    if dev.type == "cuda":
        if not torch.cuda.is_available():
            raise RuntimeError(f"device={str(dev)!r} but torch finds no CUDA device; use device='cpu'")
        dev = torch.device("cuda", torch.cuda.current_device() if dev.index is None else dev.index)
    elif dev.type != "cpu":
        raise ValueError(f"device must be 'cpu', 'cuda' or 'cuda:<index>'; got {str(dev)!r}")
    return dev


def _same_device(a: torch.device, b: torch.device) -> bool:
    return a.type == b.type and (a.type == "cpu" or a.index == b.index)
