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


@pytest.mark.parametrize("start, target", [(1.5, 0.8), (0.8, 1.5), (1.2, 0.4), (0.4, 1.2)])
def test_vergence_is_the_target_disparity(start, target):
    """The vergence command of a pure depth step is the target's disparity relative to fixation, from the
    angle the target subtends at the two eye centres (crossed: converge; uncrossed: diverge); the eyes'
    traces reach it but for the orbital plant's slow tail (< 1 %)."""
    with Head("dots", image_size=16) as head:
        plan, t, verg, vel = _vergence_trace(head, start, (target, 0.0))
        c = head.cyclopean_position
        left, right = (head.to_world(p) for p in head.eye_centres_head)
    p0, p1 = c + [start, 0.0, 0.0], c + [target, 0.0, 0.0]

    def subtended(p):
        a, b = p - left, p - right
        return math.degrees(math.acos(np.dot(a, b) / np.linalg.norm(a) / np.linalg.norm(b)))
    disparity = subtended(p1) - subtended(p0)
    (l0, r0), (l1, r1) = plan.start_angles[:, 0], plan.end_angles[:, 0]
    command = math.degrees((l1 - r1) - (l0 - r0))  # left h - right h: convergence > 0
    assert command == pytest.approx(disparity, abs=1e-9)
    assert verg[-1] - verg[0] == pytest.approx(disparity, rel=0.01)


def test_vergence_main_sequence_and_convergence_faster_than_divergence():
    """Pure vergence steps of 1-8 deg on the head's traces: the peak velocity grows with the amplitude
    (a main sequence, linear: ``|change| / (e tau)``), and a convergence is faster than the divergence
    of the same size (Hung, Zhu & Ciuffreda 1997) by ``divergence_tau_ms / tau_ms``."""
    vd = VergenceDynamics()
    peaks = {True: [], False: []}
    with Head("dots", image_size=16) as head:
        ipd = float(np.linalg.norm(np.subtract(*head.eye_centres_head)))
        far = 2.0
        for change in (1.0, 2.0, 4.0, 8.0):
            # the distance at which the vergence angle is that of ``far`` plus ``change``
            near = ipd / 2 / math.tan((2 * math.atan(ipd / 2 / far) + math.radians(change)) / 2)
            for converging, (a, b) in ((True, (far, near)), (False, (near, far))):
                _, t, verg, vel = _vergence_trace(head, a, (b, 0.0))
                size = abs(verg[-1] - verg[0])
                peak = np.abs(vel).max()
                assert peak == pytest.approx(vd.peak_velocity_deg_s(size if converging else -size), rel=0.03)
                peaks[converging].append((size, peak))
    for converging in (True, False):
        sizes, pk = np.array(peaks[converging]).T
        assert np.all(np.diff(sizes) > 0) and np.all(np.diff(pk) > 0)  # monotone main sequence
    ratio = np.array(peaks[True])[:, 1] / np.array(peaks[False])[:, 1]
    np.testing.assert_allclose(ratio, vd.divergence_tau_ms / vd.tau_ms, rtol=0.05)
    assert np.all(ratio > 1.0)


def test_divergence_slower_than_convergence_is_enforced():
    with pytest.raises(ValueError, match="convergence is faster"):
        VergenceDynamics(tau_ms=100.0, divergence_tau_ms=80.0)
