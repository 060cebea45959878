"""The vergence generator (``models.VergenceDynamics``): latency, a bell-shaped velocity profile and
saccadic facilitation, measured on the head's physics traces (the orbital plant)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import models
from models import Head, VergenceDynamics


def _vergence_trace(head, start, target, latency_ms=0):
    """Straight ahead of the cyclopean eye at distance ``start`` (m) to ``target`` = (distance, right)."""
    c = head.cyclopean_position
    start, target = c + [start, 0.0, 0.0], c + [target[0], -target[1], 0.0]
    head.reset(fixate=start)
    plan = head.plan_saccade_to(target, latency_ms=latency_ms)
    head.start_saccade(plan)
    tr = head.step_ms(plan.end_ms - head.time_ms + 50, record=True)
    verg = np.degrees(tr.angles[:, 0, 0] - tr.angles[:, 1, 0])  # left h - right h: convergence > 0
    t = tr.times_ms - plan.onset_ms
    return plan, t, verg, np.gradient(verg, t) * 1000.0


def test_pure_vergence_has_a_latency_and_a_smooth_bell_shaped_velocity():
    """A step in depth straight ahead (no version): nothing for ``latency_ms`` (Rashbass & Westheimer
    1961: ~160 ms), then a velocity that starts at zero, peaks ``tau_ms`` later and decays: slow
    (a few deg/s for a ~3 deg step), far below any saccade."""
    vd = VergenceDynamics()
    with Head("dots", image_size=16) as head:
        plan, t, verg, vel = _vergence_trace(head, 1.5, (0.8, 0.0))
    change = verg[-1] - verg[0]
    assert change > 2.0  # converging by a few degrees
    before = t < vd.latency_ms
    assert np.abs(verg[before] - verg[0]).max() < 1e-3
    start = np.searchsorted(t, vd.latency_ms)
    assert abs(vel[start + 1]) < 0.05 * vel.max()  # smooth start: no jump to the peak
    t_peak = t[np.argmax(vel)]
    assert t_peak == pytest.approx(vd.latency_ms + vd.tau_ms, abs=3.0)
    assert vel.max() == pytest.approx(change / (math.e * vd.tau_ms) * 1000.0, rel=0.03)  # s e^-s peaks at 1/e
    assert vel.max() < 20.0
    # bell: rises then falls, one peak
    k = np.argmax(vel)
    assert np.all(np.diff(vel[start + 2:k - 1]) > -1e-6) and np.all(np.diff(vel[k + 2:]) < 1e-6)


def test_a_saccade_facilitates_vergence():
    """The same change in depth with a 15 deg saccade: vergence starts with the burst, no latency, and
    runs several times faster during the saccade than alone (Enright 1984; Zee, FitzGibbon & Optican
    1992): about half of it or more is done by the saccade's offset (~45 ms), long before the pure
    vergence has started (160 ms)."""
    vd = VergenceDynamics()
    with Head("dots", image_size=16) as head:
        _, t0, v0, vel0 = _vergence_trace(head, 1.5, (0.8, 0.0))
        side = 0.8 * math.tan(math.radians(15.0))
        plan, t1, v1, vel1 = _vergence_trace(head, 1.5, (0.8, side))
    during = (t1 > 0) & (t1 < plan.offset_ms - plan.onset_ms)
    assert np.abs(vel1[during]).max() > 3.0 * vel0.max()
    done = (v1[np.searchsorted(t1, plan.offset_ms - plan.onset_ms)] - v1[0]) / (v1[-1] - v1[0])
    assert 0.4 < done < 1.0


@pytest.mark.parametrize("offset", [0.0, 60.0])
def test_settle_time_is_where_the_remainder_reaches_the_tolerance(offset):
    """``settle_ms`` inverts the response (Lambert W): the remaining fraction there is settle/change."""
    vd = VergenceDynamics(tau_ms=120.0, latency_ms=140.0)
    for change in (0.5, 2.0, 8.0):
        ts = vd.settle_ms(change, offset, 0.01)
        assert (1.0 - vd.fraction(ts, offset)) * change == pytest.approx(0.01, rel=1e-6)
    t = np.linspace(0.0, 900.0, 9001)
    smooth = np.abs(t - offset) > 0.2  # the rate steps down at the saccade's offset
    np.testing.assert_allclose(np.gradient(vd.fraction(t, offset), t)[smooth], vd.rate(t, offset)[smooth], atol=2e-4)
