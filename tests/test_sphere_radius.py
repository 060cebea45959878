"""``models.Head.set_sphere_radius``: a sphere's drawn size (the psychophysics trial sizes its flash
dots through it; it used to write the head's MuJoCo model itself, ``tests/test_boundaries.py``).

Ground truth: a sphere of radius ``r`` whose centre lies at distance ``d`` on the optical axis is
seen under the half-angle ``asin(r / d)``, so a pinhole camera draws a disc of radius
``tan(asin(r / d))`` on its unit-focal image plane, ``pixels_per_unit`` pixels per unit.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from models import Head


def _disc_pixels(head: Head, base: np.ndarray) -> int:
    diff = np.abs(head.render().left.image.astype(float) - base)
    return int((diff.reshape(diff.shape[0], diff.shape[1], -1).max(-1) > 0).sum())


def test_a_resized_sphere_draws_the_disc_of_its_visual_angle():
    with Head("dots", image_size=64, seed=0) as h:
        target = h.object_position("target")
        h.set_gaze(target)
        h.set_visible("target", False)
        base = h.render().left.image.astype(float)
        h.set_visible("target", True)
        d = float(np.linalg.norm(target - h.eye_states()[0].camera_position))  # the left eye's distance
        for r in (0.1, 0.2):
            h.set_sphere_radius("target", r)
            assert h.model.geom_size[h.model.geom("target").id, 0] == r
            rho = math.tan(math.asin(r / d)) * h.pixels_per_unit
            assert _disc_pixels(h, base) == pytest.approx(math.pi * rho**2, rel=0.15), r
        h.reset()
        assert h.model.geom_size[h.model.geom("target").id, 0] == 0.2  # a model property: reset keeps it


@pytest.mark.adversarial
def test_only_a_sphere_has_a_radius_and_a_refusal_changes_nothing():
    with Head("dots", image_size=16, seed=0) as h:
        before = h.model.geom_size.copy()
        with pytest.raises(ValueError, match="'ruler' is not a sphere"):
            h.set_sphere_radius("ruler", 0.1)
        with pytest.raises(ValueError, match="radius"):
            h.set_sphere_radius("target", -0.1)
        with pytest.raises(KeyError, match="unicorn"):
            h.set_sphere_radius("unicorn", 0.1)
        assert np.array_equal(h.model.geom_size, before)
