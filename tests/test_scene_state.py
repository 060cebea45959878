"""``models.Head.scene_state`` / ``set_scene_state``: a scene's pose, put back on another head.

The psychophysics snapshots replay a trial's scene in 3-D through this pair (they used to write
the head's MuJoCo arrays themselves; ``tests/test_boundaries.py``). Ground truth: the second
head renders the very image of the first.
"""

from __future__ import annotations

import numpy as np
import pytest

from models import Head


def test_a_posed_scene_renders_the_same_on_another_head():
    with Head("dots", image_size=16, seed=0) as a, Head("dots", image_size=16, seed=0) as b:
        a.set_gaze(a.cyclopean_position + [1.0, 0.2, 0.1])
        state = a.scene_state()
        assert set(state) == set(Head.SCENE_STATE)
        assert not np.array_equal(state["qpos"], b.scene_state()["qpos"])  # the two heads differ before
        b.set_scene_state(state)
        for k, v in b.scene_state().items():
            assert np.array_equal(v, state[k]), k
        fa, fb = a.render(), b.render()
        for ia, ib in zip(fa, fb):
            assert np.array_equal(ia.image, ib.image) and np.array_equal(ia.camera_xmat, ib.camera_xmat)
        state["qpos"][0] += 1.0  # a copy: the head is not changed through it
        assert not np.array_equal(a.scene_state()["qpos"], state["qpos"])


@pytest.mark.adversarial
@pytest.mark.parametrize("change, match", [
    (lambda s: s.pop("geom_rgba"), "lacks 'geom_rgba'"),
    (lambda s: s.update(qpos=s["qpos"][:-1]), "qpos has shape"),
    (lambda s: s["mocap_pos"].__setitem__((0, 0), np.nan), "mocap_pos holds a value that is not finite"),
])
def test_a_bad_scene_state_is_refused_and_changes_nothing(change, match):
    with Head("dots", image_size=16, seed=0) as h:
        before = h.scene_state()
        bad = h.scene_state()
        change(bad)
        with pytest.raises(ValueError, match=match):
            h.set_scene_state(bad)
        for k, v in h.scene_state().items():
            assert np.array_equal(v, before[k]), k
