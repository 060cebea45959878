"""``envs.core``: the reset checks, spaces, observation entries, ``info`` and episode end that the single
env (``BinocularSaccadeEnv``) and the batched env (``BatchedBinocularSaccade``) share (issue 37, item 3).

The rules are checked against their statements (truncation by the saccade budget only where the task
did not succeed, ``TimeLimit(K)``'s cap, gymnasium's ``_key`` masks); then both envs, on the same seed
and action, must give the same observation and info keys in the same order, and the same values where
their code is shared: the host's eye-position signal, clock and saccade plan (the first saccade starts
from the same settled reset), the clip flag and the episode's end. The vision (float64 numpy against
float32 torch) and the physics differ by design and are compared in ``tests/test_batched_env.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

from conformal import checks
from envs import core


def test_episode_end_terminates_on_success_and_truncates_at_the_budget():
    for success in (False, True):
        for saccades in (1, 2, 3):
            te, tr = core.episode_end(success, saccades, 2)
            assert bool(te) is success
            assert bool(tr) is (not success and saccades >= 2)
    success = np.array([True, False, False, True, False])
    saccades = np.array([5, 5, 1, 1, 5])
    active = np.array([True, True, True, True, False])
    te, tr = core.episode_end(success, saccades, 5, active)
    np.testing.assert_array_equal(te, [True, False, False, True, False])
    np.testing.assert_array_equal(tr, [False, True, False, False, False])  # never both; never a resetting world


def test_saccade_budget_is_capped_as_a_time_limit():
    assert core.saccade_budget(5) == core.saccade_budget(5, -1) == 5
    assert core.saccade_budget(5, 3) == 3 and core.saccade_budget(5, 9) == 5
    for bad in (0, -2, 2.5, "5"):
        with pytest.raises(ValueError, match="max_episode_steps"):
            core.saccade_budget(5, bad)


def test_reset_checks():
    assert core.world_seeds(None, 3) == [None] * 3
    assert core.world_seeds(7, 3) == [7, 8, 9]  # as gymnasium's SyncVectorEnv seeds its sub-envs
    assert core.world_seeds([1, None], 2) == [1, None]
    with pytest.raises(ValueError, match="list of 2 seeds"):
        core.world_seeds([1], 2)
    for bad in (-1, 1.5, "3", True):
        with pytest.raises(ValueError, match="seed"):
            core.check_seed(bad)
    core.check_options(None)
    core.check_options({})
    with pytest.raises(checks.InputTypeError, match="options must be a dict"):
        core.check_options([])
    with pytest.raises(ValueError, match="no reset options; got a"):
        core.check_options({"a": 1})
    with pytest.raises(RuntimeError, match=r"call reset\(\) before render\(\)"):
        core.require_reset(False, "render()")
    a, b = np.random.default_rng(4), np.random.default_rng(4)
    assert core.head_seed(a) == int(b.integers(2**31 - 1))


def test_masks_follow_each_key():
    active = np.array([True, False])
    info = core.masked({"sim_time_ms": np.zeros(2), "remap_error": {"shift": np.ones(2)}, "clipped": np.zeros(2, bool)},
                       active)
    assert list(info) == ["sim_time_ms", "_sim_time_ms", "remap_error", "_remap_error", "clipped", "_clipped"]
    assert info["_sim_time_ms"].all() and info["_remap_error"].all() and info["remap_error"]["_shift"].all()
    np.testing.assert_array_equal(info["_clipped"], active)
    assert info["_clipped"] is not active  # a copy: the env's own mask is not handed out


def _non_masks(d: dict) -> list[str]:
    return [k for k in d if not k.startswith("_")]


@pytest.mark.slow
@pytest.mark.warp
@pytest.mark.parametrize("kwargs", [{}, {"task": "free", "scene": "bar", "include_coeffs": True,
                                         "task_kwargs": {"max_saccades": 1}}])
def test_both_envs_give_the_same_info_and_observation_entries(kwargs):
    pytest.importorskip("torch")
    pytest.importorskip("mujoco_warp")
    import envs

    args = dict(image_size=32, fovea_deg=5.0, eye_drive="servo", **kwargs)
    single = envs.BinocularSaccadeEnv(**args)
    batched = envs.BatchedBinocularSaccade(1, device="cpu", output="numpy", **args)
    try:
        so, si = single.reset(seed=21)
        bo, bi = batched.reset(seed=21)
        assert list(so) == list(bo) and _non_masks(bi) == list(si)
        np.testing.assert_array_equal(so["eyes"], bo["eyes"][0])
        assert si["sim_time_ms"] == bi["sim_time_ms"][0]
        action = np.array([0.4, -0.2], np.float32)
        so, sr, ste, str_, si = single.step(action)
        bo, br, bte, btr, bi = batched.step(action[None])
        assert list(so) == list(bo)
        assert _non_masks(bi) == list(si)  # the same keys in the same order
        assert _non_masks(bi["remap_error"]) == list(si["remap_error"])
        for k in _non_masks(bi):
            assert bi["_" + k][0], k
            if k != "remap_error":
                assert np.shape(bi[k][0]) == np.shape(si[k]), k
        np.testing.assert_array_equal(so["eyes"], bo["eyes"][0])  # the host's eye-position signal
        assert si["sim_time_ms"] == bi["sim_time_ms"][0]
        for k in core.SACCADE_INFO:  # the first saccade: one planner, from the same settled reset
            np.testing.assert_array_equal(si[k], bi[k][0], err_msg=k)
        assert si["clipped"] == bi["clipped"][0] and si["success"] == bi["success"][0]
        assert (ste, str_) == (bool(bte[0]), bool(btr[0]))
        if kwargs:  # free viewing, budget 1: truncated by the budget in both
            assert str_ and not ste
    finally:
        single.close()
        batched.close()
