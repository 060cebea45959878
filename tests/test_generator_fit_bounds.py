"""One table of the burst generator's parameter ranges for the generator itself and for the fit
(``models.saccade_generator.PARAMETER_BOUNDS``), ``at_bounds`` and the refusal of unidentified fits
(issue 35, item 6)."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import models
from experiments.oculomotor import generator_fit as gf
from models.saccade_generator import PARAMETER_BOUNDS


def test_one_table_for_the_generator_and_the_fit():
    assert gf.PARAMETER_BOUNDS is PARAMETER_BOUNDS
    assert set(gf.FITTABLE) <= set(PARAMETER_BOUNDS)
    names = {f.name for f in dataclasses.fields(models.BurstGenerator)}
    assert names == set(PARAMETER_BOUNDS)
    for name, (lo, hi) in PARAMETER_BOUNDS.items():
        for ok in (lo, hi):
            models.BurstGenerator(**{name: ok})  # every value the fit may return is accepted
        for bad in (hi * 1.01, lo - 0.01 * (hi - lo)):
            with pytest.raises(ValueError, match=name):
                models.BurstGenerator(**{name: bad})


def test_identifiability_flags_bounds_and_wide_cis():
    fit = ("burst_max_deg_s", "burst_scale_deg", "adaptation_gain")
    lo = np.array([np.log(1.0), np.log(0.01), 0.0])
    hi = np.array([np.log(2000.0), np.log(50.0), 5.0])
    logs = np.array([True, True, False])

    def from_x(x):
        return np.where(logs, np.exp(x), x)

    x = np.array([np.log(600.0), np.log(0.01), 0.5])  # burst_scale on its lower bound
    ci = {"burst_max_deg_s": (550.0, 650.0), "burst_scale_deg": (0.01, 0.011), "adaptation_gain": (0.0, float("inf"))}
    at, problems = gf.identifiability(fit, x, lo, hi, ci, from_x)
    assert at == ["burst_scale_deg"]
    assert any("burst_scale_deg = 0.01 is on its lower bound" in p for p in problems)
    assert any("CI of adaptation_gain" in p for p in problems) and len(problems) == 2
    at, problems = gf.identifiability(fit, np.array([np.log(600.0), np.log(3.0), 0.5]), lo, hi,
                                      dict(ci, burst_scale_deg=(2.5, 3.5), adaptation_gain=(0.4, 0.6)), from_x)
    assert at == [] and problems == []


def test_a_ci_reaching_a_bound_is_not_identified():
    """``plant_t2_ms`` 0.507 ms against its 0.5 bound, CI [0.4988, 0.5069] (a real 500 Hz recording,
    ``mne_test_eyelink.asc``, fitted with ``plant_t2_ms``): 1.4 % from the bound, outside the
    estimate's tolerance, but the data do not exclude the bound: not identified. A CI inside the
    range near a bound is fine."""
    fit = ("burst_max_deg_s", "plant_t2_ms")
    lo, hi = np.log([1.0, 0.5]), np.log([2000.0, 50.0])
    x = np.log([597.0, 0.507])
    ci = {"burst_max_deg_s": (564.4, 633.7), "plant_t2_ms": (0.4988, 0.5069)}
    at, problems = gf.identifiability(fit, x, lo, hi, ci, np.exp)
    assert at == [] and problems == ["the 95% CI of plant_t2_ms [0.4988, 0.5069] reaches its lower bound (0.5)"]
    at, problems = gf.identifiability(fit, x, lo, hi, dict(ci, plant_t2_ms=(0.502, 0.53)), np.exp)
    assert at == [] and problems == []


def test_an_unidentified_fit_writes_no_file_and_an_identified_one_strict_json(tmp_path):
    gen = models.BurstGenerator()
    base = dict(generator=gen, fitted=("burst_max_deg_s",), estimates={"burst_max_deg_s": 714.0},
                ci95={"burst_max_deg_s": (700.0, float("inf"))}, kept_default={}, n_saccades=9, rate_hz=500.0,
                residual_sd={}, success=True, message="")
    bad = gf.FitResult(**base, problems=["the 95% CI of burst_max_deg_s [700, inf] is as wide as its whole range"])
    with pytest.raises(ValueError, match="not identified"):
        bad.to_file(tmp_path / "g.json")
    assert not (tmp_path / "g.json").exists()
    good = gf.FitResult(**dict(base, ci95={"burst_max_deg_s": (700.0, 730.0)}),
                        extra={"ci95_asymptotic": {"burst_max_deg_s": (0.0, float("inf"))}})
    good.to_file(tmp_path / "g.json")

    def refuse(name):
        raise AssertionError(f"not strict JSON: {name}")

    doc = json.loads((tmp_path / "g.json").read_text(), parse_constant=refuse)
    assert doc["at_bounds"] == [] and doc["ci95_asymptotic"]["burst_max_deg_s"] == [0.0, None]
    assert doc["bounds"]["burst_max_deg_s"] == list(PARAMETER_BOUNDS["burst_max_deg_s"])
    assert models.BurstGenerator.from_file(tmp_path / "g.json") == gen


@pytest.mark.slow
def test_a_fit_ending_on_a_bound_is_reported_not_a_crash():
    """Small saccades faster and shorter than the family can make (as on a real 500 Hz recording,
    ``mne_test_eyelink.asc``: 1-7 deg at 130-400 deg/s in 15-30 ms) drive ``burst_scale_deg`` and
    ``burst_lag_ms`` onto their lower bounds (here ``burst_max_deg_s`` onto its upper). The CIs' Jacobian then steps one-sided at the bound (it
    stepped below it, and the run died with a traceback), and the fit lists them in ``at_bounds``."""
    amps = np.linspace(1.0, 7.0, 24)
    pr = gf.predict(models.BurstGenerator(), amps, 500.0)
    rows = [{"amplitude_deg": a, "peak_velocity_deg_s": 1.6 * v * (1.0 + 0.02 * np.sin(7 * i)), "duration_ms": 0.7 * d}
            for i, (a, v, d) in enumerate(zip(pr["amplitude_deg"], pr["peak_velocity_deg_s"], pr["duration_ms"]))]
    fit = gf.fit_generator(rows, rate_hz=500.0, bootstrap=0)
    assert "burst_scale_deg" in fit.at_bounds
    assert fit.problems  # not identified: no generator.json would be written
