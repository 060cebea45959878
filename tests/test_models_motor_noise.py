"""Saccadic motor error (``models.MotorNoise``): scatter elongated along the saccade's direction and an
undershoot proportional to the amplitude, measured on many simulated endpoints against the model's
published constants (van Opstal & van Gisbergen 1989; Kowler & Blaser 1995; Becker 1989)."""

from __future__ import annotations

import numpy as np
import pytest

import models
from models import HUMAN_MOTOR_NOISE, Head, MotorNoise
from models.eye_kinematics import cyclopean_amplitude, displaced, fixation_batch, noisy_endpoints

CENTRES = np.array([[0.0, 0.032, 0.0], [0.0, -0.032, 0.0]])  # head frame: x forward, y left
C = CENTRES.mean(axis=0)


def _saccades(noise, amp_deg, direction_deg, n, seed=0):
    """n saccades of ``amp_deg`` in the Fick direction ``direction_deg`` (0 rightward, 90 up) from 1 m
    straight ahead; returns the fixation point, intended targets and executed endpoints (n, 3)."""
    fix = np.tile(C + [1.0, 0.0, 0.0], (n, 1))
    a, phi = np.radians(amp_deg), np.radians(direction_deg)
    targets = displaced(C, fix, np.tile([a * np.cos(phi), a * np.sin(phi)], (n, 1)))
    ang, ok, _ = fixation_batch(targets, CENTRES)
    assert ok.all()
    amp = cyclopean_amplitude(C, fix, targets)
    rngs = [np.random.default_rng([seed, k]) for k in range(n)]
    end, _, executed = noisy_endpoints(C, CENTRES, fix, targets, ang, amp, noise, rngs)
    return fix, targets, end, amp, executed


def _along_across(fix, targets, end):
    """Errors (rad) of the endpoints along and across each saccade's direction, in the tangent plane at
    the target (an independent construction: unit vectors and dot products)."""
    u = lambda v: v / np.linalg.norm(v, axis=1, keepdims=True)  # noqa: E731
    d0, d1, de = u(fix - C), u(targets - C), u(end - C)
    motion = u(d1 - d0 * (d0 * d1).sum(1, keepdims=True))  # direction of travel, tangent at d0 ...
    motion = u(motion - d1 * (motion * d1).sum(1, keepdims=True))  # ... carried to the target
    side = np.cross(d1, motion)
    return np.arcsin((de * motion).sum(1)), np.arcsin((de * side).sum(1))


@pytest.mark.parametrize("direction", [0.0, 45.0, 120.0, 270.0])
def test_scatter_is_elongated_along_the_saccade(direction):
    """4,000 saccades of 12 deg: the s.d. along the direction is ``along`` x amplitude, across it
    ``across`` x amplitude (ratio 1.5 for the human values), whatever the direction."""
    noise = HUMAN_MOTOR_NOISE
    fix, targets, end, amp, _ = _saccades(noise, 12.0, direction, 4000)
    along, across = _along_across(fix, targets, end)
    a = np.radians(12.0)
    assert along.std() / a == pytest.approx(noise.along, rel=0.05)
    assert across.std() / a == pytest.approx(noise.across, rel=0.05)
    assert along.std() / across.std() == pytest.approx(noise.along / noise.across, rel=0.07)
    assert abs(across.mean()) < 4 * noise.across * a / np.sqrt(len(across))  # no bias across


def test_undershoot_is_proportional_to_amplitude():
    """Executed against intended amplitude over 2-30 deg: a line through the origin of slope ``gain``
    (0.90: Becker 1989's ~10 % undershoot); with no scatter, exactly ``gain`` x amplitude."""
    intended, means = [], []
    for A in (2.0, 5.0, 10.0, 20.0, 30.0):
        _, _, _, amp, executed = _saccades(HUMAN_MOTOR_NOISE, A, 30.0, 3000, seed=int(A))
        intended.append(np.degrees(amp).mean())  # the cyclopean amplitude of the oblique target
        means.append(np.degrees(executed).mean())
    slope, intercept = np.polyfit(intended, means, 1)
    assert slope == pytest.approx(HUMAN_MOTOR_NOISE.gain, abs=0.005)
    assert abs(intercept) < 0.05
    exact = MotorNoise(gain=0.9)
    _, _, _, amp, executed = _saccades(exact, 15.0, 200.0, 5)
    np.testing.assert_allclose(executed, 0.9 * amp, rtol=1e-9)


def test_isotropic_noise_is_the_old_endpoint_noise():
    """``Head(endpoint_noise=sd)`` is ``MotorNoise.of(sd)``: the same draws as before, round scatter
    (along/across ~ 1) and no undershoot."""
    fix, targets, end, amp, executed = _saccades(0.1, 10.0, 0.0, 4000)
    fix2, targets2, end2, _, _ = _saccades(MotorNoise.of(0.1), 10.0, 0.0, 4000)
    np.testing.assert_array_equal(end, end2)
    along, across = _along_across(fix, targets, end)
    assert along.std() / across.std() == pytest.approx(1.0, abs=0.07)
    assert np.degrees(executed).mean() == pytest.approx(10.0, abs=0.1)


def test_head_draws_motor_noise_from_its_seed_and_keeps_the_efference_copy():
    """Two heads with one seed plan the same noisy saccade; the efference copy and the intended
    amplitude are the command's; the executed one is shorter on average."""
    plans = []
    for _ in range(2):
        with Head("dots", image_size=16, seed=4, motor_noise=HUMAN_MOTOR_NOISE) as h:
            h.reset()
            plans.append(h.plan_saccade(0.2, 0.1))
    a, b = plans
    np.testing.assert_array_equal(a.end_angles, b.end_angles)
    assert not np.allclose(a.end_angles, a.intended_end_angles)
    with Head("dots", image_size=16, seed=4) as h:
        h.reset()
        quiet = h.plan_saccade(0.2, 0.1)
    np.testing.assert_allclose(a.efference_copy, quiet.efference_copy, atol=1e-12)
    assert a.intended_amplitude == pytest.approx(quiet.amplitude, abs=1e-12)


def test_motor_noise_arguments_are_checked():
    with pytest.raises(ValueError, match="gain"):
        MotorNoise(gain=2.0)
    with pytest.raises(ValueError, match="along"):
        MotorNoise(along=-0.1)
    with pytest.raises(ValueError, match="not both"):
        Head("dots", image_size=16, endpoint_noise=0.1, motor_noise=HUMAN_MOTOR_NOISE)
    with pytest.raises(TypeError, match="motor_noise"):
        Head("dots", image_size=16, motor_noise=0.1)
    assert not MotorNoise().active and models.HUMAN_MOTOR_NOISE.active
