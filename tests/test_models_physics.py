"""models: physics stepping -- C-stepped fixation, tabulated saccades, timestep options, determinism."""

from __future__ import annotations

import numpy as np
import pytest

import models
from models import Head


def _run(h, chunks):
    """Fixate, saccade with latency, fixate; stepped in ``chunks`` of milliseconds."""
    h.reset()
    plan = h.plan_saccade(np.deg2rad(10), np.deg2rad(-4), latency_ms=23)
    h.start_saccade(plan)
    total = plan.end_ms - h.time_ms + 250
    done = 0
    for c in chunks:
        c = min(c, total - done)
        h.step_ms(c)
        done += c
    while done < total:
        h.step_ms(1)
        done += 1
    return h.data.qpos.copy(), h.data.qvel.copy()


def test_result_does_not_depend_on_how_time_is_chunked():
    h = Head("dots", image_size=16, seed=0)
    q1, v1 = _run(h, [10_000])  # one call: fixation in C, the saccade, fixation in C
    q2, v2 = _run(h, [1] * 40 + [7, 13, 1, 50])  # millisecond by millisecond through onset
    assert np.array_equal(q1, q2) and np.array_equal(v1, v2)


def test_same_seed_same_angles_and_renders_after_saccades():
    def go(seed):
        with Head("search", image_size=32, seed=seed, endpoint_noise=0.1) as h:
            for _ in range(3):
                h.saccade_to("target", latency_ms=20, after_ms=250)
            return h.eye_angles, h.render().left.image

    (a1, i1), (a2, i2) = go(7), go(7)
    assert np.array_equal(a1, a2) and np.array_equal(i1, i2)


def test_record_matches_unrecorded_and_uses_both_timesteps():
    a = Head("dots", image_size=16, seed=0)
    b = Head("dots", image_size=16, seed=0)
    outs = []
    for h, rec in ((a, True), (b, False)):
        plan = h.plan_saccade(np.deg2rad(10), 0.0, latency_ms=5)
        h.start_saccade(plan)
        outs.append(h.step_ms(plan.end_ms - h.time_ms + 20, record=rec))
    assert np.array_equal(a.data.qpos, b.data.qpos)
    tr = outs[0]
    steps = np.round(np.diff(tr.times_ms), 9)
    assert set(steps) == {models.DEFAULT_SACCADE_TIMESTEP_MS, models.DEFAULT_TIMESTEP_MS}
    assert np.all(np.diff(tr.times_ms) > 0) and tr.times_ms[-1] == a.time_ms
    assert a.model.opt.timestep == pytest.approx(models.DEFAULT_TIMESTEP_MS * 1e-3)


@pytest.mark.parametrize("fix_ms,sac_ms", [(0.1, 0.1), (0.5, 0.25), (1.0, 0.5)])
def test_other_timesteps_track_the_plan(fix_ms, sac_ms):
    h = Head("dots", image_size=16, seed=0, timestep_ms=fix_ms, saccade_timestep_ms=sac_ms)
    plan = h.plan_saccade_to(models.screen_point(np.deg2rad(25), np.deg2rad(20), 0.8))
    h.start_saccade(plan)
    tr = h.step_ms(plan.end_ms - h.time_ms + 50, record=True)
    assert np.rad2deg(np.abs(tr.angles - tr.planned).max()) < 0.2
    assert np.allclose(h.eye_angles, plan.end_angles, atol=np.deg2rad(0.01))


def test_fixation_holds_and_flash_expires_inside_one_long_step():
    h = Head("dots", image_size=16, seed=0)
    ang = h.eye_angles
    h.flash("flash_01", duration_ms=8)
    h.step_ms(300)
    assert h.visible_flashes == ()
    assert h.time_ms == 310
    assert np.abs(h.eye_angles - ang).max() < 1e-9


@pytest.mark.parametrize("bad", [0.3, 0.0, -1.0, 2.0, float("nan")])
def test_timestep_must_divide_one_millisecond(bad):
    with pytest.raises(ValueError, match="divide 1 ms"):
        Head("bar", image_size=16, timestep_ms=bad)
    with pytest.raises(ValueError, match="divide 1 ms"):
        Head("bar", image_size=16, saccade_timestep_ms=bad)
