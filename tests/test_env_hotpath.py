"""The env's per-step path (``Vision``'s internal entry points, which skip re-checking what the env
made itself) gives bit for bit what the public, checked path gives."""

import numpy as np
import pytest

import conformal as C
import envs
from envs.tasks import _gaze_errors_deg, gaze_errors_deg
from envs.vision import _check_rotations

MODELS = envs.REMAP_MODELS


def _rotations(seed, n=2, max_deg=25.0):
    rng = np.random.default_rng(seed)
    return np.stack([C.rotation_matrix(rng.normal(size=3), np.radians(rng.uniform(-max_deg, max_deg)))
                     for _ in range(n)])


@pytest.fixture(scope="module", params=[False, True], ids=["rgb", "gray"])
def vision(request):
    return envs.Vision((64, 64), 50.0, fovea_deg=4.0, grayscale=request.param, shift_rings=1.5)


def _images(seed, n=2):
    rng = np.random.default_rng(seed)
    return tuple(rng.integers(0, 256, (64, 64, 3), dtype=np.uint8) for _ in range(n))


@pytest.mark.parametrize("seed", range(5))
def test_map_params_equal_point_map_objects(vision, seed):
    R = _rotations(seed)
    kinds, params = vision.map_params(MODELS, R)
    ref_kinds, ref_params = vision.plan._maps([[vision.point_map(m, r) for m in MODELS] for r in R], len(R))
    assert np.array_equal(kinds, ref_kinds)
    assert np.array_equal(params, ref_params)
    # a list of rotations (not a float64 stack) takes check_rotation one by one
    assert np.array_equal(vision.map_params(MODELS, list(R.astype(np.float32).astype(float)))[1],
                          vision.plan._maps([[vision.point_map(m, r) for m in MODELS]
                                             for r in R.astype(np.float32).astype(float)], len(R))[1])


@pytest.mark.parametrize("seed", range(3))
def test_frame_path_equals_public_path(vision, seed):
    imgs = _images(seed)
    frame = vision._see_frame(imgs)
    views = vision.see_eyes(imgs)
    for v, w, s in zip(frame.views, views, frame.samples):
        for name in ("fovea", "periphery", "coeffs", "mask", "fovea_mask"):
            assert np.array_equal(getattr(v, name), getattr(w, name)), name
        assert np.array_equal(s, w.samples)
    assert np.array_equal(frame.periphery, np.stack([w.periphery for w in views]))
    R = _rotations(seed + 10)
    values, valid = vision._predict_frame(frame, MODELS, R)
    ref_values, ref_valid = vision.predict_arrays(views, MODELS, R)
    assert np.array_equal(values, ref_values) and np.array_equal(valid, ref_valid)
    after = vision._see_frame(_images(seed + 100))
    assert np.array_equal(vision._frame_errors(values, valid, after),
                          vision.errors(ref_values, ref_valid, after.views), equal_nan=True)


def test_frame_path_checks_what_it_did_not_make(vision):
    # images not of the renderer's kind (float, another shape) go through see_eyes' checks
    imgs = tuple(im / 255.0 for im in _images(0))
    assert np.array_equal(vision._see_frame(imgs).samples, np.stack([v.samples for v in vision.see_eyes(imgs)]))
    with pytest.raises(ValueError):
        vision._see_frame((np.zeros((32, 32, 3), np.uint8),) * 2)
    frame = vision._see_frame(_images(0))
    with pytest.raises(ValueError, match="one 3x3 rotation per view"):
        vision._predict_frame(frame, MODELS, _rotations(0, n=3))


@pytest.mark.parametrize("bad", ["scaled", "reflection", "nan", "inf"])
def test_rotation_stack_is_checked(bad):
    R = _rotations(1)
    if bad == "scaled":
        R[1] *= 1.01
    elif bad == "reflection":
        R[0] = -R[0]
    else:
        R[0, 1, 2] = np.nan if bad == "nan" else np.inf
    with pytest.raises(ValueError):
        C.check_rotation(R[0] if bad != "scaled" else R[1])
    with pytest.raises(ValueError):
        _check_rotations(R)


def test_gaze_errors_fast_equals_public():
    env = envs.BinocularSaccadeEnv(image_size=32)
    try:
        env.reset(seed=3)
        for a in ([0.3, 0.1], [-0.2, 0.25]):
            env.step(np.array(a, np.float32))
            p = env.head.object_position("target")
            assert np.array_equal(_gaze_errors_deg(env.head, p), gaze_errors_deg(env.head, p))
    finally:
        env.close()
