"""The fit's motor noise marginalised (``ForwardModel.motor_draws``): each trial observed with K landing
errors of its own, the rows' prediction their mean and the likelihood's variance the report noise's plus
theirs -- against direct sums with scipy.stats, a grid search for the noise's maximum and the errors of
the options."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from experiments.modelfit.data import LocalizationData, read_data
from experiments.modelfit.forward import ForwardModelError, draw_seed, forward_model
from experiments.modelfit.likelihood import FIT_MODELS, NOISE, Evaluator
from experiments.psychophysics import TrialConfig

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "experiments" / "data" / "example_localization.csv"


class _Runner:
    """A runner whose read-out of an observation is the observation itself (its perceived x, y)."""

    config = TrialConfig()

    @staticmethod
    def readout(o, cfg):
        return {"perceived_x_deg": o[0], "perceived_y_deg": o[1]}


def _evaluator(draws: np.ndarray, n=(1, 3, 2), sd=None) -> tuple[Evaluator, LocalizationData]:
    """Three rows, each its own cell read out as ``draws[row]`` (K, 2) under K landing errors."""
    k = draws.shape[1]
    perceived = np.array([[11.5, 2.0], [5.0, -2.0], [9.0, 0.5]])
    data = LocalizationData(
        np.array([20.0, 20.0, 20.0]),
        np.array([-50, 0, 50]),
        np.array([[12.0, 3.0], [4.0, -3.0], [8.0, 1.0]]),
        perceived,
        np.array(["references"] * 3),
        np.array(n),
        np.full((3, 2), np.nan) if sd is None else np.asarray(sd, float),
    )
    obs = [tuple(draws[r, j]) for r in range(3) for j in range(k)]
    row_trial = np.arange(3 * k).reshape(3, k)
    return Evaluator(FIT_MODELS["paper"], data, {"references": _Runner()}, {"references": obs}, row_trial), data


VALUES = {p.name: p.default for p in FIT_MODELS["paper"].parameters if not p.name.startswith("noise")}


def _direct_ll(data, draws, sx, sy) -> float:
    """The log-likelihood as a direct sum: each axis' row mean ~ N(mean of the draws, (s^2 + v) / n), v
    the draws' variance (ddof 1); a row's reports' s.d. s: (n - 1) s^2 / (s^2 + v) ~ chi2(n - 1)."""
    from scipy.stats import chi2, norm

    mean, v = draws.mean(axis=1), draws.var(axis=1, ddof=1)
    total = 0.0
    for r in range(len(data)):
        for ax, s in enumerate((sx, sy)):
            tot = s**2 + v[r, ax]
            total += norm.logpdf(data.perceived_deg[r, ax], mean[r, ax], math.sqrt(tot / data.n[r]))
            if np.isfinite(data.sd_deg[r, ax]) and data.n[r] >= 2:
                k = data.n[r] - 1
                total += chi2.logpdf(k * data.sd_deg[r, ax] ** 2 / tot, k) + math.log(k / tot)
    return total


def test_prediction_is_the_draws_mean_and_the_likelihood_adds_their_variance():
    rng = np.random.default_rng(0)
    draws = np.array([[11.0, 2.5], [4.0, -1.0], [9.5, 0.0]])[:, None, :] + rng.normal(0, 0.8, (3, 5, 2))
    ev, data = _evaluator(draws, sd=[[np.nan, np.nan], [1.2, 0.7], [0.9, np.nan]])
    np.testing.assert_allclose(ev.predict(VALUES), draws.mean(axis=1), rtol=1e-12)
    np.testing.assert_allclose(ev.motor_variance(VALUES), draws.var(axis=1, ddof=1), rtol=1e-12)
    v = {**VALUES, "noise_x_deg": 0.9, "noise_y_deg": 1.7}
    assert ev.log_likelihood(v) == pytest.approx(_direct_ll(data, draws, 0.9, 1.7), rel=1e-10)
    # without the draws' variance the same data would be fitted with a smaller likelihood at small noise
    ev0, _ = _evaluator(np.repeat(draws.mean(axis=1, keepdims=True), 2, axis=1), sd=data.sd_deg)
    assert ev0.log_likelihood({**v, "noise_x_deg": 0.3}) != pytest.approx(ev.log_likelihood({**v, "noise_x_deg": 0.3}))


def test_noise_mle_with_draws_is_the_likelihoods_maximum():
    """The report noise is profiled numerically with draws: no s.d. on a fine grid does better."""
    rng = np.random.default_rng(1)
    draws = np.array([[11.0, 2.5], [4.0, -1.0], [9.5, 0.0]])[:, None, :] + rng.normal(0, 1.1, (3, 6, 2))
    ev, data = _evaluator(draws, sd=[[np.nan, np.nan], [1.2, 0.7], [0.9, np.nan]])
    best = ev.noise_mle(VALUES)
    ll_best = ev.log_likelihood(best)
    grid = np.geomspace(NOISE[0].lo, NOISE[0].hi, 1001)  # steps of under 1 %
    for name in ("noise_x_deg", "noise_y_deg"):
        lls = [ev.log_likelihood({**best, name: float(s)}) for s in grid]
        assert max(lls) <= ll_best + 1e-6, name
        assert NOISE[0].lo <= best[name] <= NOISE[0].hi


def test_a_lost_draw_leaves_the_others_and_too_few_lose_the_row():
    draws = np.array([[[11.0, 2.0], [12.0, 2.5], [np.nan, np.nan]],
                      [[4.0, -1.0], [np.nan, np.nan], [np.nan, np.nan]],
                      [[9.0, 0.0], [9.5, 0.5], [10.0, 1.0]]])
    ev, _ = _evaluator(draws)
    pred = ev.predict(VALUES)
    np.testing.assert_allclose(pred[0], [11.5, 2.25])
    assert np.all(np.isnan(pred[1]))  # one draw of three saw the flash: no variance, no prediction
    assert ev.log_likelihood({**VALUES, "noise_x_deg": 1.0, "noise_y_deg": 1.0}) == -math.inf


def test_draw_seeds_are_per_cell_and_reproducible():
    a = [draw_seed(20.0, -50, 4.0, 3.0, k) for k in range(8)]
    assert a == [draw_seed(20, -50, 4.000000001, 3.0, k) for k in range(8)]  # the cell, to 1e-6 deg
    assert len(set(a)) == 8 and all(0 <= s < 2**31 for s in a)
    assert not set(a) & {draw_seed(20.0, 0, 4.0, 3.0, k) for k in range(8)}


def test_forward_model_motor_draws_are_checked():
    data = read_data(EXAMPLE)
    fwd = forward_model(data, {"endpoint_noise": 0.05}, note=False, motor_draws=4)
    assert fwd.motor_draws == 4 and fwd.fingerprint()["motor_draws"] == 4
    assert "motor_draws" not in forward_model(data, {"endpoint_noise": 0.05}, note=False).fingerprint()
    with pytest.raises(ForwardModelError, match="forward model has none"):
        forward_model(data, note=False, motor_draws=4)  # the example's sidecar: no endpoint noise
    for bad in (1, 65, -2, True, 2.5):
        with pytest.raises(ForwardModelError, match="motor_draws must be 0"):
            forward_model(data, {"endpoint_noise": 0.05}, note=False, motor_draws=bad)


def test_cli_motor_draws_without_motor_noise_is_a_usage_error(tmp_path):
    r = subprocess.run(
        [sys.executable, "-m", "experiments", "fit", "--data", str(EXAMPLE), "--model", "observer",
         "--out", str(tmp_path / "f"), "--motor-draws", "3"],
        capture_output=True, text=True, cwd=ROOT,
    )
    assert r.returncode == 2 and "forward model has none" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "f").exists()


@pytest.mark.slow
def test_fit_with_motor_draws_observes_each_cell_k_times(tmp_path):
    """A tiny fit at 64 px with K = 2: each design cell observed twice (two landing errors), the
    fingerprint in fit.json saying so, and a re-run a no-op."""
    from experiments.modelfit.fitting import fit, prepare

    rows = EXAMPLE.read_text().splitlines()
    small = tmp_path / "small.csv"
    small.write_text("\n".join(rows[:1] + [r for r in rows[1:] if ",-150," in r or ",0," in r][:6]) + "\n")
    data = read_data(small)
    fwd = forward_model(data, {"endpoint_noise": 0.05, "image_size": 64}, note=False, motor_draws=2)
    _, observations, row_trial = prepare(data, None, fwd)
    assert row_trial.shape == (len(data), 2)
    cells = {(a, t, x, y) for a, t, (x, y) in zip(data.amplitude_deg, data.flash_time_ms, fwd.offset_deg)}
    assert sum(len(v) for v in observations.values()) == 2 * len(cells)
    r = fit(data, "observer", tmp_path / "fit", max_evals=6, forward=fwd)
    assert r["forward_model"]["config"]["motor_draws"] == 2
    assert fit(data, "observer", tmp_path / "fit", max_evals=6, forward=fwd)["fit_key"] == r["fit_key"]
