"""Why fits of the burst generator end on a bound (issue 35, item 6): the diagnosis tools
(``experiments.oculomotor.fit_diagnosis``) against analytic cases and sessions of known parameters,
and the fit's handling of a bound that ``exp(log(bound))`` rounds past."""

from __future__ import annotations

import numpy as np
import pytest

import models
from experiments.oculomotor import eyetracking as et
from experiments.oculomotor import fit_diagnosis as fd
from experiments.oculomotor import generator_fit as gf


@pytest.mark.parametrize("t2_ms", [5.0, 7.4, 13.0])
@pytest.mark.parametrize("burst_max", [450.0, 800.0])
def test_a_saturated_burst_peaks_as_a_rectangular_pulse_through_t2(t2_ms, burst_max):
    """With ``burst_scale_deg`` near 0 and a negligible lag, the burst is a rectangle of height B and
    area A (pulse-width modulation); through ``1 / (1 + s T2)`` the eye's speed peaks at its end at
    ``B (1 - exp(-A / (B T2)))``: the closed form against the simulated loop. Adaptation is off (it
    lowers the burst as it goes)."""
    g = models.BurstGenerator(
        burst_max_deg_s=burst_max, burst_scale_deg=0.01, burst_lag_ms=0.1, adaptation_gain=0.0, plant_t2_ms=t2_ms
    )
    amps = np.array([0.5, 1.5, 3.0, 6.0])
    pos, _ = g.simulate(amps, span_ms=150.0, dt_ms=0.01)
    peak = (np.diff(pos[0], axis=0) / 0.01).max(axis=0) * 1000.0
    assert peak == pytest.approx(fd.saturated_burst_peak_deg_s(amps, burst_max, t2_ms), rel=0.03)


def test_the_saturated_burst_peak_is_a_saturating_main_sequence():
    """``B (1 - exp(-A / C))`` with ``C = B T2``: small amplitudes ``A / T2``, large ones ``B``."""
    assert fd.saturated_burst_peak_deg_s(0.001, 500.0, 7.4) == pytest.approx(0.001 / 7.4e-3, rel=1e-3)
    assert fd.saturated_burst_peak_deg_s(60.0, 500.0, 7.4) == pytest.approx(500.0, rel=1e-6)
    with pytest.raises(ValueError):
        fd.saturated_burst_peak_deg_s(1.0, 0.0, 7.4)


@pytest.mark.slow
def test_bin_table_matches_a_session_of_the_same_generator():
    """A session simulated from known parameters, read and measured as a recording: each bin's
    median peak velocity and duration agree with the same generator's prediction at the bin's
    median amplitude (the same estimator on both sides), and differ from another generator's."""
    g = models.BurstGenerator(burst_max_deg_s=600.0, burst_scale_deg=4.0)
    s = et.synthetic_session(g, n_saccades=40, rate_hz=500.0, noise_deg=0.0, seed=3, amplitudes=(1.0, 25.0))
    rec = et.Recording(et.Path("session"), "csv", s["times_ms"], s["x_deg"], s["y_deg"], 500.0)
    rows = et.main_sequence_rows(rec)
    same = fd.bin_table(rows, g, rate_hz=500.0)
    assert len(same) >= 3
    for r in same:
        assert r["pv_data"] == pytest.approx(r["pv_model"], rel=0.03)
        assert r["du_data"] == pytest.approx(r["du_model"], rel=0.03)
    other = fd.bin_table(rows, models.BurstGenerator(), rate_hz=500.0)
    assert max(abs(r["pv_data"] / r["pv_model"] - 1) for r in other) > 0.1


@pytest.mark.slow
def test_a_fit_reaching_a_bound_that_rounds_is_kept_on_it(monkeypatch):
    """``exp(log(5.0))`` is 4.999999999999999: a fit on a log scale that reaches a lower bound of 5
    must build its generator on the bound, not fail with 'must be in [5, 20]'. Saccades of a plant
    faster than the bound allows drive ``plant_t2_ms`` onto it; the fit says so."""
    truth = models.BurstGenerator(burst_max_deg_s=550.0, plant_t2_ms=2.5)
    s = et.synthetic_session(truth, n_saccades=30, rate_hz=500.0, noise_deg=0.0, seed=5, amplitudes=(2.0, 20.0))
    rec = et.Recording(et.Path("session"), "csv", s["times_ms"], s["x_deg"], s["y_deg"], 500.0)
    rows = et.main_sequence_rows(rec)
    monkeypatch.setitem(gf.PARAMETER_BOUNDS, "plant_t2_ms", (5.0, 20.0))
    f = gf.fit_generator(rows, fit=("burst_max_deg_s", "plant_t2_ms"), rate_hz=500.0, bootstrap=0)
    assert f.at_bounds == ["plant_t2_ms"]
    assert f.generator.plant_t2_ms == pytest.approx(5.0, rel=1e-6)


@pytest.mark.slow
def test_the_saturated_fit_recovers_a_session_of_known_parameters():
    """A session simulated from a saturated burst (``burst_scale_deg`` held at ``SATURATED_SCALE_DEG``,
    ceiling 550 deg/s, lag 5 ms), fitted with ``SATURATED_FIT`` and the scale held: both estimates
    within their 95 % CIs of the truth (asymptotic CIs here; the bootstrap's coverage over 20
    sessions is in docs/eyetracker.md) and nothing on a bound."""
    truth = dict(burst_max_deg_s=550.0, burst_lag_ms=5.0)
    held = models.BurstGenerator(burst_scale_deg=gf.SATURATED_SCALE_DEG)
    g = models.BurstGenerator(burst_scale_deg=gf.SATURATED_SCALE_DEG, **truth)
    s = et.synthetic_session(g, n_saccades=60, rate_hz=500.0, noise_deg=0.02, seed=7)
    rec = et.Recording(et.Path("session"), "csv", s["times_ms"], s["x_deg"], s["y_deg"], 500.0)
    f = gf.fit_generator(
        et.main_sequence_rows(rec),
        fit=gf.SATURATED_FIT,
        rate_hz=500.0,
        noise_deg=rec.noise_deg,
        bootstrap=0,
        start=held,
    )
    assert f.at_bounds == [] and f.problems == []
    assert f.kept_default["burst_scale_deg"] == gf.SATURATED_SCALE_DEG
    for name, value in truth.items():
        lo, hi = f.ci95[name]
        assert lo <= value <= hi, (name, f.estimates[name], (lo, hi))
