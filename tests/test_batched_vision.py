"""``envs.batched_vision.TorchVision`` (B worlds x 2 eyes in torch) against the CPU ``envs.vision.Vision``.

The CPU path is the ground truth: for each world, ``Vision._see_frame``, ``_predict_frame`` (the point
prediction), ``_frame_errors`` and ``BinocularSaccadeEnv._cortical``. The batch mixes real renders of
the dots scene (before and after a saccade, with the saccade's efference copy), random pictures, large
rotations and identity rotations (the env's resetting worlds).

Why the tolerances are not zero: the CPU pools, weighs and Fourier-transforms the samples in float64
and evaluates the series with float32 tables built in float64 (angles by a float64 rotation
recurrence, rings by a float64 Chebyshev recurrence); ``TorchVision`` does all of it in float32
(complex64): float32 sums in the pooling (~1e-7 of the intensity), a float32 FFT and a float32
complex product with the mirror-series map (~1e-7 of the largest coefficient, amplified up to
e^(M delta) ~ rb / r0 on the inner rings by the e^{-u_k} weights), the points mapped in float32
(~1e-7 relative) and cos(n y), cos(m t) taken directly of float32 arguments up to ~N/2 pi (~1e-6
absolute). The rotations themselves are float32, as the batched env passes them (the CPU gets the
same float32 values in float64). Each tolerance below is a few times the largest difference
measured on this batch (stated beside it).
"""

from __future__ import annotations

import math
import types

import numpy as np
import pytest

torch = pytest.importorskip("torch")

import conformal as C  # noqa: E402
import models  # noqa: E402
from envs.batched_vision import TorchFrame, TorchVision  # noqa: E402
from envs.saccade_env import BinocularSaccadeEnv  # noqa: E402
from envs.vision import REMAP_MODELS, Vision  # noqa: E402

DEVICES = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])

# |samples - CPU| (intensities in [0, 1]); measured 2.9e-7 (64 px), 2.6e-7 (128 px).
TOL_SAMPLES = 1e-6
# |coeffs - CPU| / max |CPU coeffs| per world; measured 1.1e-7 (64 and 128 px).
TOL_COEFFS = 1e-6
# |predicted values - CPU| where both are valid (intensities): ``_series_tolerance``, the worst-case float32
# error of the mirror series, as neither side fixes the order of its sums. Measured on this batch (64 px: 8
# rings x 20 sectors): 9.8e-7 (0.5-1.8 eps x L1) with torch's thread count set, but 2.0e-5 (20 eps x L1, on
# the random pictures' world) in a process that had not set it: torch's matrix product then blocked its sums
# differently. A fixed 1e-5 failed the suite once that way.
# |errors / CPU errors - 1|; measured 3.3e-6 (64 px), 1.5e-7 (128 px).
TOL_ERRORS = 3e-5
# A valid-mask cell may differ only where the CPU's mapped point lies within this relative distance
# (in |w|^2) of r0^2 or r_b^2 (float32 rounding of the mapped point); measured: no cell differs, here
# nor in 1.1e6 cells of 1000 worlds with 45 deg rotations.
TOL_BOUNDARY = 1e-5
# ... and at most this fraction of all cells may differ so; measured 0.
MAX_BOUNDARY_FRACTION = 1e-3
# The batch against the worlds one at a time (different batch sizes may take different float32
# reduction orders in the matrix products); measured 2.1e-7. Samples only: predicted values are series
# sums and get ``_series_tolerance``.
TOL_BATCH = 2e-6


def _series_tolerance(vis: Vision, coeffs) -> float:
    """The largest difference two float32 evaluations of the mirror series of ``coeffs`` (E, M, N, C DPFT
    coefficients: one world's eyes) may show, whatever order each sums in: each value is a sum of J M terms
    S x a x b with |a|, |b| <= 1 (the angular and ring factors), so each side's rounding error is at most
    (J M + pi N / 2) eps sum |S| -- gamma_n sum |x_i| for the sum (Higham 2002, Accuracy and Stability of
    Numerical Algorithms, eq. 3.5) plus the factors' error, cos(n y) of a float32 angle y being off by up
    to n |dy| <= (N / 2) pi eps; twice that for two sides. L1 = sum |S| over the series (the largest eye)."""
    from conformal.dpft import _mirror_series

    g = vis.grid
    series = _mirror_series(np.asarray(coeffs, np.complex128), g, np.float64)
    terms = series.shape[-1] * g.M + math.pi * g.N / 2
    return float(2 * terms * np.finfo(np.float32).eps * np.abs(series).sum(axis=(1, 2)).max())


def _rotations(seed: int, max_deg: float) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.stack([C.rotation_matrix(rng.normal(size=3), np.radians(rng.uniform(-max_deg, max_deg)))
                     for _ in range(2)])


@pytest.fixture(scope="module")
def scene():
    """A batch of four worlds (64 px): the dots scene before a saccade (with its efference copy), after
    it (random 25 deg rotations), random pictures (random 40 deg rotations; identity rotations). Each
    world's "after" frame is the next world's pictures (world 0's: the post-saccadic render)."""
    head = models.Head("dots", image_size=64, seed=0)
    head.reset()
    f0 = head.render()
    plan = head.plan_saccade(0.2, -0.1)
    efference = plan.efference_copy_eye
    head.start_saccade(plan)
    head.step_ms(plan.end_ms - head.time_ms + 50)
    f1 = head.render()
    shape, ppu = head.image_shape, head.pixels_per_unit
    head.close()
    rng = np.random.default_rng(7)
    images = np.stack([
        np.stack([f0.left.image, f0.right.image]),
        np.stack([f1.left.image, f1.right.image]),
        rng.integers(0, 256, (2, 64, 64, 3), dtype=np.uint8),
        rng.integers(0, 256, (2, 64, 64, 3), dtype=np.uint8),
    ])
    rotations = np.stack([efference, _rotations(1, 25.0), _rotations(2, 40.0), np.stack([np.eye(3)] * 2)])
    return types.SimpleNamespace(shape=shape, ppu=ppu, images=images, after=images[[1, 2, 3, 0]],
                                 rotations=rotations.astype(np.float32))


CASES = {"rgb": {}, "gray-shift": {"grayscale": True, "shift_rings": 1.5}}


@pytest.fixture(scope="module", params=[(c, d) for c in CASES for d in DEVICES], ids=lambda p: f"{p[0]}-{p[1]}")
def case(request, scene):
    """The CPU Vision's results per world and TorchVision's for the batch."""
    name, device = request.param
    vis = Vision(scene.shape, scene.ppu, **CASES[name])
    tv = TorchVision(vis, device)
    rot64 = scene.rotations.astype(np.float64)  # the same (float32) numbers the device gets
    cpu = []
    for b in range(len(scene.images)):
        frame = vis._see_frame(tuple(scene.images[b]))
        values, valid = vis._predict_frame(frame, REMAP_MODELS, rot64[b])
        after = vis._see_frame(tuple(scene.after[b]))
        cpu.append(types.SimpleNamespace(frame=frame, values=values, valid=valid, after=after,
                                         errors=vis._frame_errors(values, valid, after)))
    frame = tv.see(torch.as_tensor(scene.images, device=device))
    values, valid = tv.predict(frame, torch.as_tensor(scene.rotations, device=device), REMAP_MODELS)
    after = tv.see(torch.as_tensor(scene.after, device=device))
    errors = tv.errors(values, valid, after)
    return types.SimpleNamespace(vis=vis, tv=tv, device=device, cpu=cpu, frame=frame, values=values, valid=valid,
                                 after=after, errors=errors, rot64=rot64)


def _np(t: torch.Tensor) -> np.ndarray:
    return t.detach().cpu().numpy()


def _boundary_distance(vis: Vision, rotation: np.ndarray, model: str) -> np.ndarray:
    """Relative distance in |w|^2 of each retina point's CPU image w (float64) from r0^2 and r_b^2."""
    g = vis.grid
    z = np.concatenate([g.fovea_points, g.points.ravel()])
    with np.errstate(all="ignore"):
        w = vis.point_map(model, rotation)(z)
    rr = np.abs(w) ** 2
    return np.minimum(np.abs(rr / g.r0**2 - 1), np.abs(rr / g.ring_edges[-1] ** 2 - 1))


def _check_predictions(vis, rot64, cpu_values, cpu_valid, values, valid, coeffs) -> int:
    """Compare one world's predictions (E, K, P, C) from its DPFT ``coeffs``; returns the number of mask
    cells that differ."""
    differ = cpu_valid != valid
    for e, k, i in zip(*np.nonzero(differ)):
        assert _boundary_distance(vis, rot64[e], REMAP_MODELS[k])[i] < TOL_BOUNDARY, (e, k, i)
    both = cpu_valid & valid
    np.testing.assert_allclose(values[both], cpu_values[both], rtol=0, atol=_series_tolerance(vis, coeffs))
    assert np.all(values[~valid] == 0)  # invalid cells hold 0
    return int(differ.sum())


# ---------------------------------------------------------------------- frames
def test_samples_and_coeffs(case):
    f = case.frame
    g = case.vis.grid
    c = case.vis.channels
    assert isinstance(f, TorchFrame)
    assert f.samples.shape == (4, 2, g.n_fovea + g.M * g.N, c) and f.samples.dtype == torch.float32
    assert f.periphery.shape == (4, 2, g.M, g.N, c) and f.fovea.shape == (4, 2, g.n_fovea, c)
    assert f.coeffs.shape == (4, 2, g.M, g.N, c) and f.coeffs.dtype == torch.complex64
    assert torch.equal(f.periphery.reshape(4, 2, -1, c), f.samples[:, :, g.n_fovea:])
    assert torch.equal(f.fovea, f.samples[:, :, :g.n_fovea])
    for b, ref in enumerate(case.cpu):
        np.testing.assert_allclose(_np(f.samples[b]), ref.frame.samples, rtol=0, atol=TOL_SAMPLES)
        np.testing.assert_allclose(_np(f.periphery[b]), ref.frame.periphery, rtol=0, atol=TOL_SAMPLES)
        np.testing.assert_allclose(_np(f.fovea[b]), ref.frame.fovea, rtol=0, atol=TOL_SAMPLES)
        scale = np.abs(ref.frame.coeffs).max()
        assert np.abs(_np(f.coeffs[b]) - ref.frame.coeffs).max() <= TOL_COEFFS * scale
    assert torch.equal(case.tv.valid.cpu(), torch.as_tensor(case.vis._valid))


def test_float_images_and_see_samples(case, scene):
    """Float pictures in [0, 1] give the uint8 pictures' samples; ``see_samples`` of the CPU retina's
    samples (``Vision._frame``'s input) gives the same frame as ``see``."""
    images = torch.as_tensor(scene.images, device=case.device)
    floats = case.tv.see(images.to(torch.float32) / 255.0)
    torch.testing.assert_close(floats.samples, case.frame.samples, rtol=0, atol=TOL_SAMPLES)
    raw = np.stack([case.vis.retina.sample_many(tuple(im), 1 / 255) for im in scene.images])
    from_samples = case.tv.see_samples(torch.as_tensor(raw, dtype=torch.float32, device=case.device))
    torch.testing.assert_close(from_samples.samples, case.frame.samples, rtol=0, atol=TOL_SAMPLES)
    scale = case.frame.coeffs.abs().max().item()
    torch.testing.assert_close(from_samples.coeffs, case.frame.coeffs, rtol=0, atol=TOL_COEFFS * scale)


# ---------------------------------------------------------------------- remapping
def test_map_params_equal_cpu(case):
    rot = torch.as_tensor(case.rot64, device=case.device)  # float64: the CPU's own numbers
    kinds, params = case.tv.map_params(REMAP_MODELS, rot)
    for b in range(len(case.rot64)):
        ref_kinds, ref_params = case.vis.map_params(REMAP_MODELS, case.rot64[b])
        assert kinds == tuple(ref_kinds)
        # the homography is a permutation (exact); the Mobius and shift parameters agree to a few ulp
        # (hypot and division in another order): measured 1.1e-16
        np.testing.assert_array_equal(_np(params[b, :, 0]), ref_params[:, 0])
        np.testing.assert_allclose(_np(params[b]), ref_params, rtol=0, atol=1e-15)


def test_predictions_match_cpu(case):
    assert case.values.shape == (4, 2, 3, case.tv.n_points, case.vis.channels)
    assert case.values.dtype == torch.float32 and case.valid.dtype == torch.bool
    values, valid = _np(case.values), _np(case.valid)
    differ = sum(_check_predictions(case.vis, case.rot64[b], ref.values, ref.valid, values[b], valid[b],
                                    ref.frame.coeffs) for b, ref in enumerate(case.cpu))
    assert differ <= MAX_BOUNDARY_FRACTION * valid.size
    # the batch exercises every branch: the old fovea, the series, and cells with no source
    assert valid.any() and (~valid).any()
    assert valid[2].mean() < valid[3].mean()  # 40 deg rotations lose more of the picture than none
    # identity rotations: the homography and the Mobius map predict the frame itself (the series reproduces
    # the samples at the grid points; the fovea lands on its own lattice), within the series' float32 error
    # (the shift model also scales by e^(shift_rings delta))
    assert valid[3, :, :2].all()
    np.testing.assert_allclose(values[3, :, :2], np.stack([_np(case.frame.samples[3])] * 2, axis=1),
                               rtol=0, atol=1e-4)


def test_errors_match_cpu(case):
    assert case.errors.shape == (4, 2, 3) and case.errors.dtype == torch.float32
    errors = _np(case.errors)
    for b, ref in enumerate(case.cpu):
        np.testing.assert_allclose(errors[b], ref.errors, rtol=TOL_ERRORS, atol=0)
    # no valid cell: NaN, as the CPU
    none = torch.zeros_like(case.valid)
    ref = case.vis._frame_errors(case.cpu[0].values, np.zeros_like(case.cpu[0].valid), case.cpu[0].after)
    assert np.isnan(ref).all() and torch.isnan(case.tv.errors(case.values, none, case.after)).all()


@pytest.mark.parametrize("cortex", ["eyes", "hemispheres"])
def test_cortical_matches_env(case, cortex):
    """``cortical`` of the samples and of the chosen model's prediction, as ``BinocularSaccadeEnv._cortical``."""
    env = types.SimpleNamespace(cortex=cortex, vision=case.vis)
    g = case.vis.grid
    chosen = case.values[:, :, 0, g.n_fovea:].reshape(4, 2, g.M, g.N, -1)
    series = [_series_tolerance(case.vis, r.frame.coeffs) for r in case.cpu]
    for per, ref_per, tol in ((case.frame.periphery, [r.frame.periphery for r in case.cpu], [TOL_SAMPLES] * 4),
                              (chosen, [r.values[:, 0, g.n_fovea:].reshape(2, g.M, g.N, -1) for r in case.cpu],
                               series)):
        out = case.tv.cortical(per, cortex)
        assert out.dtype == torch.float32
        for b, ref in enumerate(ref_per):
            expected = BinocularSaccadeEnv._cortical(env, ref)
            assert out[b].shape == expected.shape
            np.testing.assert_allclose(_np(out[b]), expected, rtol=0, atol=tol[b])


def test_grayscale_is_channel_mean(scene):
    """Grayscale samples are the mean of the RGB samples (the pooling is linear), C = 1 throughout."""
    rgb = TorchVision(Vision(scene.shape, scene.ppu))
    gray = TorchVision(Vision(scene.shape, scene.ppu, grayscale=True))
    images = torch.as_tensor(scene.images)
    f_rgb, f_gray = rgb.see(images), gray.see(images)
    assert f_gray.samples.shape[-1] == 1 and f_gray.coeffs.shape[-1] == 1
    torch.testing.assert_close(f_gray.samples, f_rgb.samples.mean(-1, keepdim=True), rtol=0, atol=TOL_SAMPLES)
    values, valid = gray.predict(f_gray, torch.as_tensor(scene.rotations), REMAP_MODELS)
    assert values.shape[-1] == 1 and gray.cortical(f_gray.periphery, "hemispheres").shape[-1] == 1


# ---------------------------------------------------------------------- batching
def test_batch_equals_worlds_one_at_a_time(case, scene):
    tv, dev = case.tv, case.device
    for b in range(len(scene.images)):
        frame = tv.see(torch.as_tensor(scene.images[b:b + 1], device=dev))
        values, valid = tv.predict(frame, torch.as_tensor(scene.rotations[b:b + 1], device=dev), REMAP_MODELS)
        after = tv.see(torch.as_tensor(scene.after[b:b + 1], device=dev))
        torch.testing.assert_close(frame.samples[0], case.frame.samples[b], rtol=0, atol=TOL_BATCH)
        assert torch.equal(valid[0], case.valid[b])
        torch.testing.assert_close(values[0], case.values[b], rtol=0,
                                   atol=_series_tolerance(case.vis, case.cpu[b].frame.coeffs))
        torch.testing.assert_close(tv.errors(values, valid, after)[0], case.errors[b], rtol=TOL_BATCH, atol=0)


def test_no_cross_talk_and_chunks(case, scene):
    """Other worlds' pictures and rotations leave a world's results unchanged (same batch shape): its
    samples, coefficients and validity bit for bit, its predictions within the float32 error bound of
    their series (torch's matrix product may block its sums differently with another thread count, as
    a test before it in the process may set: seen once in CI, bit-unequal); so do chunks of any size
    (here one world's eyes at a time). Cross-talk would move world 0's values by the other worlds'
    inverted pictures: far beyond the bound."""
    tv, dev = case.tv, case.device
    images = torch.as_tensor(scene.images, device=dev).clone()
    rotations = torch.as_tensor(scene.rotations, device=dev).clone()
    images[1:] = 255 - images[1:]
    rotations[1:] = rotations[1:].flip(0)
    frame = tv.see(images)
    values, valid = tv.predict(frame, rotations, REMAP_MODELS)
    assert torch.equal(frame.samples[0], case.frame.samples[0]) and torch.equal(frame.coeffs[0], case.frame.coeffs[0])
    tol = max(_series_tolerance(case.vis, r.frame.coeffs) for r in case.cpu)
    assert torch.equal(valid[0], case.valid[0])
    torch.testing.assert_close(values[0], case.values[0], rtol=0, atol=tol)
    chunked = TorchVision(case.vis, dev, chunk_bytes=1 << 16)
    v2, m2 = chunked.predict(case.frame, torch.as_tensor(scene.rotations, device=dev), REMAP_MODELS)
    assert torch.equal(m2, case.valid)
    torch.testing.assert_close(v2, case.values, rtol=0, atol=tol)


def test_128px_against_cpu():
    """One larger retina (128 px: 15 rings x 36 sectors, shift_rings = -2) on two worlds of random pictures."""
    head = models.Head("dots", image_size=128, seed=0)
    shape, ppu = head.image_shape, head.pixels_per_unit
    head.close()
    vis = Vision(shape, ppu, shift_rings=-2.0)
    tv = TorchVision(vis)
    rng = np.random.default_rng(3)
    images = rng.integers(0, 256, (2, 2, 128, 128, 3), dtype=np.uint8)
    rotations = np.stack([_rotations(5, 20.0), _rotations(6, 30.0)]).astype(np.float32)
    frame = tv.see(torch.as_tensor(images))
    values, valid = tv.predict(frame, torch.as_tensor(rotations), REMAP_MODELS)
    errors = tv.errors(values, valid, frame)
    for b in range(2):
        ref = vis._see_frame(tuple(images[b]))
        np.testing.assert_allclose(_np(frame.samples[b]), ref.samples, rtol=0, atol=TOL_SAMPLES)
        assert np.abs(_np(frame.coeffs[b]) - ref.coeffs).max() <= TOL_COEFFS * np.abs(ref.coeffs).max()
        r64 = rotations[b].astype(np.float64)
        ref_values, ref_valid = vis._predict_frame(ref, REMAP_MODELS, r64)
        assert _check_predictions(vis, r64, ref_values, ref_valid, _np(values[b]), _np(valid[b]), ref.coeffs) == 0
        np.testing.assert_allclose(_np(errors[b]), vis._frame_errors(ref_values, ref_valid, ref), rtol=TOL_ERRORS)


def test_large_rotation_and_invalid_shift_target(scene):
    """A 120 deg turn: homography and Mobius predict (mostly invalid cells) as the CPU; the shift model has
    no target in front of the eye and raises, naming the world, as the CPU path raises."""
    vis = Vision(scene.shape, scene.ppu)
    tv = TorchVision(vis)
    rotations = scene.rotations.copy()
    rotations[2, 1] = C.rotation_matrix([1.0, 0.0, 0.0], np.radians(120.0))
    rot = torch.as_tensor(rotations)
    frame = tv.see(torch.as_tensor(scene.images))
    with pytest.raises(ValueError, match="the shift model needs") as cpu_error:
        vis._predict_frame(vis._see_frame(tuple(scene.images[2])), REMAP_MODELS, rotations[2].astype(np.float64))
    with pytest.raises(ValueError, match=r"world 2, eye 1: the shift model needs the new optical axis in front"):
        tv.predict(frame, rot, REMAP_MODELS)
    with pytest.raises(ValueError, match="world 2, eye 1"):
        tv.map_params(("shift",), rot)
    assert "in front of the old eye" in str(cpu_error.value)
    two = ("homography", "mobius")
    values, valid = tv.predict(frame, rot, two)
    ref_frame = vis._see_frame(tuple(scene.images[2]))
    r64 = rotations[2].astype(np.float64)
    ref_values, ref_valid = vis._predict_frame(ref_frame, two, r64)
    assert ref_valid[1, 0].mean() < 0.2  # the homography: most of the new retina was behind the old eye
    differ = ref_valid != _np(valid[2])
    for e, k, i in zip(*np.nonzero(differ)):
        assert _boundary_distance(vis, r64[e], two[k])[i] < TOL_BOUNDARY
    both = ref_valid & _np(valid[2])
    np.testing.assert_allclose(_np(values[2])[both], ref_values[both], rtol=0,
                               atol=_series_tolerance(vis, ref_frame.coeffs))


# ---------------------------------------------------------------------- bad input
@pytest.fixture(scope="module")
def small(scene):
    vis = Vision(scene.shape, scene.ppu)
    tv = TorchVision(vis)
    frame = tv.see(torch.as_tensor(scene.images[:2]))
    rot = torch.as_tensor(scene.rotations[:2])
    values, valid = tv.predict(frame, rot, REMAP_MODELS)
    return types.SimpleNamespace(vis=vis, tv=tv, frame=frame, rot=rot, values=values, valid=valid,
                                 images=torch.as_tensor(scene.images[:2]))


def _bad_rotation(rot: torch.Tensor, where: tuple[int, int], value) -> torch.Tensor:
    out = rot.clone()
    out[where] = value
    return out


BAD = {
    # see
    "images numpy": (lambda s: s.tv.see(s.images.numpy()), TypeError, "torch.Tensor"),
    "images 4-d": (lambda s: s.tv.see(s.images[0]), ValueError, r"\(B, E, H, W, 3\)"),
    "images wrong size": (lambda s: s.tv.see(s.images[..., :32, :, :]), ValueError, "64, 64, 3"),
    "images no worlds": (lambda s: s.tv.see(s.images[:0]), ValueError, "B, E >= 1"),
    "images int32": (lambda s: s.tv.see(s.images.to(torch.int32)), TypeError, "uint8"),
    "images bool": (lambda s: s.tv.see(s.images > 0), TypeError, "uint8"),
    "images float 0..255": (lambda s: s.tv.see(s.images.float()), ValueError,
                            r"\[0, 1\]; world 0 has values in \[0, 29\]"),
    "images negative": (lambda s: s.tv.see(s.images.float() / 255 - torch.tensor([0, 1.0]).view(2, 1, 1, 1, 1)),
                        ValueError, "world 1"),
    "images other device": (lambda s: s.tv.see(torch.empty((1, 2, 64, 64, 3), dtype=torch.uint8, device="meta")),
                            ValueError, "is on meta"),
    "check_range not bool": (lambda s: s.tv.see(s.images, check_range=1), TypeError, "check_range"),
    "samples wrong P": (lambda s: s.tv.see_samples(torch.zeros(1, 2, 5, 3)), ValueError, r"\(B, E, P, 3\)"),
    "samples int": (lambda s: s.tv.see_samples(torch.zeros((1, 2, s.tv.n_points, 3), dtype=torch.int64)),
                    TypeError, "floating"),
    # predict
    "frame not a frame": (lambda s: s.tv.predict(s.images, s.rot, REMAP_MODELS), TypeError, "TorchFrame"),
    "models a string": (lambda s: s.tv.predict(s.frame, s.rot, "shift"), TypeError, "models"),
    "models empty": (lambda s: s.tv.predict(s.frame, s.rot, ()), TypeError, "models"),
    "unknown model": (lambda s: s.tv.predict(s.frame, s.rot, ("affine",)), ValueError, "affine"),
    "rotations numpy": (lambda s: s.tv.predict(s.frame, s.rot.numpy(), REMAP_MODELS), TypeError, "torch.Tensor"),
    "rotations int": (lambda s: s.tv.predict(s.frame, s.rot.to(torch.int64), REMAP_MODELS), TypeError, "floating"),
    "rotations per world": (lambda s: s.tv.predict(s.frame, s.rot[:1], REMAP_MODELS), ValueError,
                            r"\(2, 2, 3, 3\)"),
    "rotations 3x4": (lambda s: s.tv.predict(s.frame, torch.zeros(2, 2, 3, 4), REMAP_MODELS), ValueError, "3, 3"),
    "rotation scaled": (lambda s: s.tv.predict(s.frame, _bad_rotation(s.rot, (1, 0), 1.1 * torch.eye(3)),
                                               REMAP_MODELS),
                        ValueError, r"world 1, eye 0\) must be a proper rotation"),
    "rotation reflection": (lambda s: s.tv.predict(s.frame, _bad_rotation(s.rot, (0, 1), -torch.eye(3)), REMAP_MODELS),
                            ValueError, r"world 0, eye 1\) must be a proper rotation"),
    "rotation NaN": (lambda s: s.tv.predict(s.frame, _bad_rotation(s.rot, (1, 1), torch.full((3, 3), float("nan"))),
                                            REMAP_MODELS), ValueError, r"world 1, eye 1"),
    "rotations other device": (lambda s: s.tv.predict(s.frame, s.rot.to("meta"), REMAP_MODELS), ValueError, "meta"),
    # errors
    "errors numpy": (lambda s: s.tv.errors(s.values.numpy(), s.valid, s.frame), TypeError, "torch tensors"),
    "errors wrong P": (lambda s: s.tv.errors(s.values[..., :5, :], s.valid[..., :5], s.frame),
                       ValueError, "B, E, K, P, C"),
    "errors float64": (lambda s: s.tv.errors(s.values.double(), s.valid, s.frame), TypeError, "float32"),
    "errors valid float": (lambda s: s.tv.errors(s.values, s.valid.float(), s.frame), ValueError, "valid must be bool"),
    "errors other batch": (lambda s: s.tv.errors(s.values[:1], s.valid[:1], s.frame), ValueError, "B, E, K, P, C"),
    # cortical
    "cortex unknown": (lambda s: s.tv.cortical(s.frame.periphery, "v1"), ValueError, "cortex"),
    "cortex periphery shape": (lambda s: s.tv.cortical(s.frame.samples, "eyes"), ValueError, r"\(B, E, M, N, C\)"),
    "hemispheres one eye": (lambda s: s.tv.cortical(s.frame.periphery[:, :1], "hemispheres"), ValueError, "E = 2"),
    # construction
    "vision not a Vision": (lambda s: TorchVision(s.vis.grid), TypeError, "Vision"),
    "pooled vision": (lambda s: TorchVision(Vision(s.vis.image_shape, s.vis.pixels_per_unit, pooled_remap=True)),
                      ValueError, "point prediction"),
    "device unknown": (lambda s: TorchVision(s.vis, "tpu"), ValueError, "device"),
    "device type": (lambda s: TorchVision(s.vis, 0), TypeError, "device"),
    "chunk_bytes tiny": (lambda s: TorchVision(s.vis, chunk_bytes=10), ValueError, "chunk_bytes"),
}


@pytest.mark.adversarial
@pytest.mark.parametrize("name", list(BAD))
def test_bad_input(small, name):
    call, error, match = BAD[name]
    with pytest.raises(error, match=match):
        call(small)


@pytest.mark.adversarial
@pytest.mark.skipif(torch.cuda.is_available(), reason="CUDA is available here")
def test_cuda_without_cuda(small):
    with pytest.raises(RuntimeError, match="no CUDA"):
        TorchVision(small.vis, "cuda")


def test_hemispheres_need_n_divisible_by_4(scene):
    vis = Vision(scene.shape, scene.ppu, n_sectors=18)
    tv = TorchVision(vis)
    frame = tv.see(torch.as_tensor(scene.images[:1]))
    assert tv.cortical(frame.periphery, "eyes").shape == frame.periphery.shape
    with pytest.raises(ValueError, match="divisible by 4"):
        tv.cortical(frame.periphery, "hemispheres")


def test_tf32_is_off_inside_predict_and_restored():
    """A caller's TF32 setting (which would put ~1e-3 errors into the series' products) is switched off for
    the products on CUDA and restored after them (the flag exists on CPU builds too)."""
    from envs.batched_vision import _ieee_matmul

    matmul = torch.backends.cuda.matmul
    if not hasattr(torch.backends.cuda.matmul, "fp32_precision"):
        pytest.skip("torch < 2.9: no fp32_precision")
    before = matmul.fp32_precision
    try:
        matmul.fp32_precision = "tf32"
        with _ieee_matmul(torch.device("cuda")):
            assert matmul.fp32_precision == "ieee"
        assert matmul.fp32_precision == "tf32"
        with _ieee_matmul(torch.device("cpu")):
            assert matmul.fp32_precision == "tf32"
    finally:
        matmul.fp32_precision = before


pytestmark = pytest.mark.warp  # needs the gpu extra (Warp, MuJoCo Warp, torch): see the README's "Tests"
