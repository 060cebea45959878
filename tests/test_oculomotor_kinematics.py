"""The one way a saccade is measured (``experiments.oculomotor.kinematics``): the Savitzky--Golay
velocity against analytic derivatives, its refusal to span missing data, and the bias of its peak
velocity at 250, 500, 1000 and 2000 Hz on simulated saccades (issue 35, item 5)."""

from __future__ import annotations

import numpy as np
import pytest

from experiments.oculomotor import kinematics as K


@pytest.mark.parametrize("dt", [4.0, 2.0, 1.0, 0.5])
def test_sg_derivative_is_exact_on_quadratics(dt):
    """A least-squares quadratic's centre slope is the derivative of any quadratic (Savitzky & Golay
    1964): x = 1 + 30 t + 200 t^2 (t in s) has velocity 30 + 400 t."""
    t = np.arange(200) * dt / 1000.0
    v = K.velocity(1.0 + 30.0 * t + 200.0 * t ** 2, dt)
    m = K.sg_half_window(dt)
    assert np.isnan(v[:m]).all() and np.isnan(v[-m:]).all()
    np.testing.assert_allclose(v[m:-m], (30.0 + 400.0 * t)[m:-m], rtol=1e-9)
    assert 2 * m * dt == pytest.approx(K.SG_SPAN_MS, abs=dt)  # the window spans ~4 ms at every rate (>= 3 samples)


def test_no_velocity_spans_missing_data():
    t = np.arange(100) * 2.0
    t[50:] += 1000.0  # a pause
    x = np.linspace(0, 1, 100)
    x[20] = np.nan  # a lost sample
    v = K.velocity(x, 2.0, K.steps_ok(t, 2.0))
    m = K.sg_half_window(2.0)
    assert np.isnan(v[20 - m:20 + m + 1]).all() and np.isfinite(v[20 - m - 1]) and np.isfinite(v[20 + m + 1])
    assert np.isnan(v[50 - m:50 + m]).all() and np.isfinite(v[50 - m - 1]) and np.isfinite(v[50 + m])
    block = np.repeat([0, 1], 50)  # a block boundary without a time gap still splits
    v = K.velocity(np.linspace(0, 1, 100), 2.0, K.steps_ok(np.arange(100) * 2.0, 2.0, block))
    assert np.isnan(v[49]) and np.isnan(v[50]) and np.isfinite(v[48 - m + 1])


def peak_ratios(rate: float, noise_deg: float, amplitudes=(5.0, 10.0, 15.0, 20.0, 30.0), seed: int = 0):
    """Peak velocity of the generator's saccades sampled at ``rate`` (8 sampling phases) with Gaussian
    tracker noise on both axes: (Savitzky--Golay / true, sample-to-sample / true), each (n_amp,),
    mean over phases; true = the noise-free peak on the 0.05 ms simulation grid."""
    import models
    from models.saccade_generator import simulate

    g = models.BurstGenerator()
    A = np.asarray(amplitudes)
    p = simulate(g, A, span_ms=250.0, dt_ms=0.05)[0][0]
    true = np.abs(np.diff(p, axis=0)).max(axis=0) / 0.05 * 1000.0
    k = int(round(1000.0 / rate / 0.05))
    rng = np.random.default_rng(seed)
    sg, s2s = [], []
    for ph in np.linspace(0, k - 1, 8).astype(int):
        x = p[ph::k]
        x = x + rng.normal(0, noise_deg, x.shape)
        y = rng.normal(0, noise_deg, x.shape)
        sg.append([np.nanmax(K.speed_deg_s(x[:, j], y[:, j], 1000.0 / rate)) for j in range(len(A))])
        s2s.append((np.hypot(np.diff(x, axis=0), np.diff(y, axis=0)) * rate).max(axis=0))
    return np.mean(sg, 0) / true, np.mean(s2s, 0) / true


@pytest.mark.parametrize("rate, lo", [(250, 0.93), (500, 0.97), (1000, 0.97), (2000, 0.97)])
def test_peak_velocity_bias_by_rate(rate, lo):
    """Noise-free: the estimator's peak is within a few % of the true peak at 5-30 deg (at 250 Hz,
    7 % at 5 deg: 3 samples span 8 ms), never above it; the numbers are the README's table."""
    sg, _ = peak_ratios(rate, 0.0)
    assert np.all(sg >= lo) and np.all(sg <= 1.0 + 1e-9), sg


def test_peak_velocity_at_500_hz_within_10_percent_of_sample_to_sample():
    """Issue 35, item 5: at 500 Hz the estimate is within 10 % of the sample-to-sample one on the same
    saccades (tracker noise 0.03 deg, EyeLink 1000's order in practice); the old five-point speed read
    ~0.8x at 500 Hz."""
    sg, s2s = peak_ratios(500, 0.03)
    assert np.all(np.abs(sg / s2s - 1.0) < 0.10), sg / s2s


@pytest.mark.parametrize("rate", [200.0, 500.0, 2000.0])
def test_batched_measure_is_the_one_by_one_measure_to_the_bit(rate):
    """``measure_saccades`` (columns measured together, what the generator fit's forward model runs) gives
    exactly what ``measure_saccade`` gives one trace at a time at its peak, including the traces it cannot
    measure: a crossing meets a NaN, a side never falls below threshold, a peak at the first or last sample,
    a flat top (no parabola), and ``velocity`` of a (n, c) array is its columns' velocities."""
    dt = 1000.0 / rate
    t = np.arange(160) * dt + 3.0
    rng = np.random.default_rng(int(rate))
    c = 40
    centre = rng.uniform(40, 120, c) * dt
    width = rng.uniform(3, 30, c)
    x = 10.0 / (1 + np.exp(-(t[:, None] - centre) / width * 4)) + rng.normal(0, 0.01, (len(t), c))
    x[rng.integers(0, len(t), 6), rng.integers(0, c, 6)] = np.nan  # lost samples, some on a crossing's walk
    x[:, 0] = np.linspace(0, 40, len(t))  # never below threshold: no crossing on either side
    x[:, 1] = 10 * (t / t[-1]) ** 2  # fastest at the last sample
    x[:, 2] = 10 * (1 - t / t[-1]) ** 2  # fastest at the first sample
    v = K.velocity(x, dt)
    for j in range(c):
        np.testing.assert_array_equal(v[:, j], K.velocity(x[:, j], dt))
    s = np.abs(v)
    s[:, 3] = np.where(np.isfinite(s[:, 3]), 0.0, np.nan)
    s[70:73, 3] = 200.0  # a flat top: no parabola through it
    got = K.measure_saccades(t, s, rate)
    for j in range(c):
        if np.isnan(s[:, j]).all():
            continue
        one = K.measure_saccade(t, s[:, j], int(np.nanargmax(s[:, j])), rate)
        want = np.full(5, np.nan) if one is None else np.array(one, float)
        np.testing.assert_array_equal(got[:, j], want, err_msg=f"column {j}")
    assert np.isnan(got[:, :3]).all() and np.isfinite(got[:4]).any()
