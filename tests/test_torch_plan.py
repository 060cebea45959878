"""``conformal.TorchRemapPlan``: the DPFT and the remapping series in torch (issue 37, item 3), beside
the compiled kernels.

Ground truth: the float64 DPFT (``conformal.dpft``) and the compiled point prediction
(``conformal.RemapPlan``, numba) on the same grid, coefficients and maps, to float32 rounding; the
batched env's vision (``envs.batched_vision.TorchVision``) runs exactly this code, bit for bit; and
``import conformal`` needs no torch (checked in a subprocess with torch blocked).
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import conformal as C

ROOT = Path(__file__).resolve().parents[1]


def test_conformal_imports_without_torch():
    """With torch unimportable, ``import conformal`` works and imports no torch; asking for the torch
    plan raises an ImportError that says what to install. The same block makes ``import torch`` fail,
    so the test can fail."""
    code = textwrap.dedent("""
        import sys
        sys.modules["torch"] = None  # import torch now raises ImportError
        import conformal
        import conformal.kernels
        assert sys.modules["torch"] is None, "something replaced the block"
        assert "conformal.torch_plan" not in sys.modules
        try:
            conformal.TorchRemapPlan
        except ImportError as exc:
            print("refused:", exc)
        try:
            import torch
        except ImportError:
            print("torch blocked")
    """)
    res = subprocess.run([sys.executable, "-c", code], env=dict(os.environ, PYTHONPATH=str(ROOT)),
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert "refused: conformal.torch_plan needs torch" in res.stdout and "[gpu]" in res.stdout
    assert "torch blocked" in res.stdout


@pytest.fixture(scope="module")
def setup():
    torch = pytest.importorskip("torch")
    g = C.RetinaGrid.from_field_of_view(0.7, 0.05, 24)
    rng = np.random.default_rng(3)
    periphery = rng.uniform(0.0, 1.0, (3, g.M, g.N, 2))
    fovea = rng.uniform(0.0, 1.0, (3, g.n_fovea, 2))
    plan = C.TorchRemapPlan(g, torch.device("cpu"))
    return torch, g, plan, periphery, fovea


def test_dpft_is_conformals_dpft(setup):
    """The torch DPFT of (E, M, N, C) float32 samples is ``conformal.dpft`` to float32 rounding."""
    torch, g, plan, periphery, _ = setup
    coeffs = plan.dpft(torch.as_tensor(periphery, dtype=torch.float32)).numpy()
    ref = np.stack([C.dpft(p, g) for p in periphery])
    assert coeffs.dtype == np.complex64
    assert np.abs(coeffs - ref).max() <= 1e-5 * np.abs(ref).max()


def test_series_is_the_compiled_point_prediction(setup):
    """The torch series at the homography's and the Moebius map's points is ``RemapPlan``'s compiled
    point prediction of the same coefficients (float32 rounding; masks equal away from the radii)."""
    torch, g, plan, periphery, fovea = setup
    F = np.stack([C.dpft(p, g) for p in periphery])
    rots = [C.euler_rotation(a, b, -a) for a, b in ((0.1, 0.15), (0.4, -0.2), (0.0, 0.0))]
    maps = [[C.homography_map(R), C.mobius_map(R)] for R in rots]
    ref_values, ref_valid = C.RemapPlan(g)(F, fovea, maps)
    kinds = tuple(m.kind for m in maps[0])
    params = torch.as_tensor(np.array([[m.params for m in eye] for eye in maps]), dtype=torch.float32)
    values, valid = plan.evaluate_prechecked(torch.as_tensor(F, dtype=torch.complex64),
                                             torch.as_tensor(fovea, dtype=torch.float32), kinds, params)
    values, valid = values.numpy(), valid.numpy()
    assert values.shape == ref_values.shape and valid.shape == ref_valid.shape
    assert (valid != ref_valid).mean() < 0.002
    both = valid & ref_valid
    assert both.mean() > 0.5
    np.testing.assert_allclose(values[both], ref_values[both], rtol=0, atol=2e-4)
    assert np.all(values[~valid] == 0)
    # the identity (third eye): the series reproduces the samples at the grid's own points
    n_f = g.n_fovea
    for k in range(2):
        np.testing.assert_allclose(values[2, k, n_f:].reshape(g.M, g.N, 2), periphery[2], rtol=0, atol=2e-4)


def test_batched_vision_runs_conformals_torch_series(setup):
    """``TorchVision`` (the batched env's vision) adds no arithmetic of its own to the DPFT and the series:
    its frame's coefficients and its predictions are the plan's, bit for bit."""
    torch, *_ = setup
    models = pytest.importorskip("models")
    from envs.batched_vision import TorchVision
    from envs.vision import REMAP_MODELS, Vision

    head = models.Head("dots", image_size=48, seed=0)
    try:
        vis = Vision(head.image_shape, head.pixels_per_unit)
    finally:
        head.close()
    tv = TorchVision(vis, "cpu")
    rng = np.random.default_rng(4)
    images = torch.as_tensor(rng.integers(0, 256, (2, 2, 48, 48, 3), dtype=np.uint8))
    frame = tv.see(images)
    assert torch.equal(frame.coeffs, tv.plan.dpft(frame.periphery))
    rot = torch.as_tensor(np.stack([[C.euler_rotation(0.2 * w, 0.1 * e, 0.0) for e in range(2)] for w in range(2)]))
    values, valid = tv.predict(frame, rot, REMAP_MODELS)
    kinds, params = tv.map_params(REMAP_MODELS, rot)
    c = frame.samples.shape[-1]
    v2, ok2 = tv.plan.evaluate_prechecked(frame.coeffs.reshape(4, vis.grid.M, vis.grid.N, c),
                                          frame.fovea.reshape(4, -1, c), kinds,
                                          params.to(torch.float32).reshape(4, len(REMAP_MODELS), 9))
    assert torch.equal(values.reshape(v2.shape), v2) and torch.equal(valid.reshape(ok2.shape), ok2)
