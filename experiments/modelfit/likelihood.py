"""Fit models, their free parameters, and the likelihood of a localization data set.

Response model: each report is the model's perceived position plus independent Gaussian report
noise per axis, s.d. ``noise_x_deg`` and ``noise_y_deg`` (free parameters). A row that is the
mean of n reports has s.d. noise/sqrt(n); a row that also gives its SDs adds the likelihood of
the sample variance ((n-1) s^2 / noise^2 ~ chi-square with n-1 degrees of freedom). A 1-D row
(``perceived_y_deg`` empty: only the error along the saccade measured) contributes its x term
alone; with no y anywhere, ``noise_y_deg`` is not identified (held at its default, not counted).

Models (``FIT_MODELS``) and their free parameters (bounds; the rest of ``TrialConfig`` at defaults):

* ``mechanistic``: ``feedback_gain`` (ms/deg, 0-20), ``eps_sigma_ms`` (5-200), ``eps_delay_ms``
  (-100-200), noise. The visual latency is fixed (70 ms): with the signal's delay only their
  difference is identifiable.
* ``mechanistic/no_command_remap``: the same with the remapping off (``feedback_gain`` = 0):
  nested in ``mechanistic`` (a likelihood-ratio test with 1 df, the parameter on its bound: the
  p value is halved, Self & Liang 1987).
* ``mechanistic/no_references``: the anchored route off (not nested: a different fixed weight).
* ``paper``: the set time course's ``peak_gain`` (0-3), ``peak_time_ms`` (-200-200), ``rise_ms``
  and ``decay_ms`` (2-200), noise.
* ``observer``: ``prior_sd_deg`` (0.5-50, the references' prior) and ``temporal_sd_ms`` (5-150, the
  flash's timing uncertainty) of ``ObserverParams``, noise.
* ``population``: ``gain_per_deg`` (0-2000, the feedback gain) and ``tau_ms`` (2-100, the feedback
  signal's time constant) of ``PopulationParams``, noise.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..psychophysics.observer import ObserverParams
from ..psychophysics.population import PopulationParams
from ..psychophysics.timecourse import RemapTimeCourse
from ..psychophysics.trial_fields import TRIAL_DEFAULTS

__all__ = ["Parameter", "FitModel", "FIT_MODELS", "NESTED", "Evaluator"]


@dataclass(frozen=True)
class Parameter:
    """A free parameter: its ``default`` (the fit's start, and the value ``simulate``, ``recovery`` and
    ``crossval`` generate data with) and bounds."""

    name: str
    default: float
    lo: float
    hi: float


# The defaults are the models' own (one home: the constants the scoreboard runs with), read here, not
# repeated: a constant re-set in its model is the fit's start and the simulations' truth at once.
_OBS, _POP, _TC = ObserverParams(), PopulationParams(), RemapTimeCourse()
NOISE = (Parameter("noise_x_deg", 1.0, 0.02, 20.0), Parameter("noise_y_deg", 1.0, 0.02, 20.0))
MECH = (
    Parameter("feedback_gain", TRIAL_DEFAULTS["feedback_gain"], 0.0, 20.0),
    Parameter("eps_sigma_ms", TRIAL_DEFAULTS["eps_sigma_ms"], 5.0, 200.0),
    Parameter("eps_delay_ms", TRIAL_DEFAULTS["eps_delay_ms"], -100.0, 200.0),
)
OBSERVER = (
    Parameter("prior_sd_deg", _OBS.prior_sd_deg, 0.5, 50.0),
    Parameter("temporal_sd_ms", _OBS.temporal_sd_ms, 5.0, 150.0),
)
POPULATION = (
    Parameter("gain_per_deg", _POP.gain_per_deg, 0.0, 2000.0),
    Parameter("tau_ms", _POP.tau_ms, 2.0, 100.0),
)
PAPER = (
    Parameter("peak_gain", _TC.peak_gain, 0.0, 3.0),
    Parameter("peak_time_ms", _TC.peak_time_ms, -200.0, 200.0),
    Parameter("rise_ms", _TC.rise_ms, 2.0, 200.0),
    Parameter("decay_ms", _TC.decay_ms, 2.0, 200.0),
)


@dataclass(frozen=True)
class FitModel:
    """A model to fit: fixed ``TrialConfig`` settings and free parameters."""

    name: str
    config: dict
    parameters: tuple[Parameter, ...]

    def trial_config(self, base, values: dict):
        """``base`` (a TrialConfig) with this model's settings and parameter ``values`` (noise excluded)."""
        from ..psychophysics import RemapTimeCourse

        kw = dict(self.config)
        tc = {k: values[k] for k in ("peak_gain", "peak_time_ms", "rise_ms", "decay_ms") if k in values}
        if tc:
            kw["timecourse"] = RemapTimeCourse(**{**dataclasses.asdict(RemapTimeCourse()), **tc})
        kw.update({k: v for k, v in values.items() if k in ("feedback_gain", "eps_sigma_ms", "eps_delay_ms")})
        for group, params in (("observer", OBSERVER), ("population", POPULATION)):
            mine = {p.name: values[p.name] for p in params if p.name in values}
            if mine:
                kw[group] = dataclasses.replace(getattr(base, group), **mine)
        return dataclasses.replace(base, **kw)


FIT_MODELS = {
    "mechanistic": FitModel("mechanistic", {"model": "mechanistic"}, MECH + NOISE),
    "mechanistic/no_command_remap": FitModel(
        "mechanistic/no_command_remap", {"model": "mechanistic", "disabled": ("command_remap",)}, MECH[1:] + NOISE
    ),
    "mechanistic/no_references": FitModel(
        "mechanistic/no_references", {"model": "mechanistic", "disabled": ("references",)}, MECH + NOISE
    ),
    "paper": FitModel("paper", {"model": "paper"}, PAPER + NOISE),
    "observer": FitModel("observer", {"model": "observer"}, OBSERVER + NOISE),
    "population": FitModel("population", {"model": "population"}, POPULATION + NOISE),
}
#: restricted model -> (the model it is nested in, extra parameters, the parameter on a bound?)
NESTED = {"mechanistic/no_command_remap": ("mechanistic", 1, True)}


class Evaluator:
    """Log-likelihood of ``data`` under a model for parameter values, reading the cached
    observations (``observations[condition][k]`` for unique trial ``k``) with ``runner.readout``.

    ``row_trial`` (R,): each row's trial. Or (R, K): the row's design cell under K landing errors
    (``ForwardModel.motor_draws``): the row's prediction is the mean of the K read-outs (NaN unless
    at least two saw the flash) and their variance ``v`` (ddof 1) is the motor noise's share of
    a report's: a row of n reports has variance ``(noise^2 + v) / n``, and its reports' sample
    variance ``s^2`` gives ``(n - 1) s^2 / (noise^2 + v) ~ chi2(n - 1)``."""

    def __init__(self, model: FitModel, data, runners: dict, observations: dict, row_trial: np.ndarray):
        self.model, self.data, self.runners, self.observations = model, data, runners, observations
        self.row_trial = row_trial  # (R,) or (R, K): index into the unique trials of each row's condition
        self.evaluations = 0
        self._memo: dict = {}

    def predict(self, values: dict) -> np.ndarray:
        """Perceived positions (R, 2) of every data row for parameter ``values``."""
        return self.predict_with_variance(values)[0]

    def motor_variance(self, values: dict) -> np.ndarray:
        """The motor noise's variance (R, 2) of each row's read-out: 0 without draws (``row_trial`` 1-D)."""
        if np.ndim(self.row_trial) == 1:
            return np.zeros((len(self.data), 2))
        return self.predict_with_variance(values)[1]

    def predict_with_variance(self, values: dict) -> tuple[np.ndarray, np.ndarray]:
        """``predict`` and the motor noise's variance (R, 2) of each row's read-out (0 without draws)."""
        key = tuple(round(values[p.name], 12) for p in self.model.parameters if not p.name.startswith("noise"))
        if key in self._memo:
            return self._memo[key]
        pred = np.empty((len(self.data), 2))
        var = np.zeros((len(self.data), 2))
        for cond, obs_list in self.observations.items():
            runner = self.runners[cond]
            cfg = self.model.trial_config(runner.config, values)
            per_trial = np.array(
                [[r["perceived_x_deg"], r["perceived_y_deg"]] for r in (runner.readout(o, cfg) for o in obs_list)]
            )
            rows = self.data.condition == cond
            got = per_trial[self.row_trial[rows]]  # (r, 2) or (r, K, 2)
            if got.ndim == 2:
                pred[rows] = got
                continue
            seen = np.isfinite(got).sum(axis=1)  # (r, 2)
            with np.errstate(invalid="ignore", divide="ignore"):
                mean = np.nansum(got, axis=1) / seen
                dev = np.where(np.isfinite(got), got - mean[:, None], 0.0)
                v = np.sum(dev**2, axis=1) / (seen - 1)
            enough = seen >= 2
            pred[rows] = np.where(enough, mean, np.nan)
            var[rows] = np.where(enough, v, 0.0)
        self.evaluations += 1
        if len(self._memo) > 64:
            self._memo.clear()
        self._memo[key] = (pred, var)
        return pred, var

    def _log_likelihood(self, sig: np.ndarray, resid: np.ndarray, motor_var: np.ndarray, axes: slice) -> float:
        """The log-likelihood summed over the rows and the ``axes`` (a slice of x, y) at report-noise s.d.
        ``sig`` (2,): each row's mean report ~ N(prediction, (sig^2 + v) / n), and a row that gives its
        reports' s.d. s adds the density of s^2, (n-1) s^2 / (sig^2 + v) ~ chi2(n-1)."""
        d = self.data
        m = d.measured[:, axes]
        n = d.n[:, None].astype(float)
        total = np.asarray(sig, float)[axes] ** 2 + motor_var[:, axes]
        var = total / n
        r = resid[:, axes]
        ll = float(np.sum(np.where(m, -0.5 * (np.log(2 * np.pi * var) + r**2 / var), 0.0)))
        has_sd = np.isfinite(d.sd_deg[:, axes]) & (n >= 2) & m
        if has_sd.any():  # (n-1) s^2 / total ~ chi2(n-1), as a density of s^2
            from scipy.stats import chi2

            k = (n - 1) * np.ones((1, m.shape[1]))
            s2 = d.sd_deg[:, axes] ** 2
            with np.errstate(divide="ignore"):  # rows of one report (k 0) are masked out below
                scale = total / k
            ll += float(
                np.sum(
                    np.where(
                        has_sd,
                        chi2.logpdf(np.where(has_sd, s2, 1.0) / scale, np.where(has_sd, k, 2.0)) - np.log(scale),
                        0.0,
                    )
                )
            )
        return ll

    def noise_mle(self, values: dict) -> dict:
        """The report-noise s.d. per axis that maximizes the likelihood for the other ``values``
        (closed form without motor draws: (sum n r^2 + sum (n-1) s^2) / (rows + sum (n-1)) per axis;
        with them a bounded 1-D maximization per axis)."""
        pred, motor_var = self.predict(values), self.motor_variance(values)
        d = self.data
        n = d.n[:, None].astype(float)
        m = d.measured
        resid = np.where(m, d.perceived_deg - pred, 0.0)
        has_sd = np.isfinite(d.sd_deg) & (n >= 2) & m
        num = np.sum(np.where(m, n * resid**2, 0.0), axis=0) + np.sum(
            np.where(has_sd, (n - 1) * np.nan_to_num(d.sd_deg) ** 2, 0.0), axis=0
        )
        den = np.sum(m, axis=0) + np.sum(np.where(has_sd, n - 1, 0.0), axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):
            s = np.sqrt(num / den)
        lo, hi = NOISE[0].lo, NOISE[0].hi
        s = np.clip(np.where(np.isfinite(s), s, hi), lo, hi)
        if np.any(motor_var > 0) and np.all(np.isfinite(pred[m])):
            from scipy.optimize import minimize_scalar

            for ax in range(2):
                if den[ax] > 0 and np.any(motor_var[m[:, ax], ax] > 0):
                    res = minimize_scalar(
                        lambda sd, ax=ax: (
                            -self._log_likelihood(np.array([sd, sd]), resid, motor_var, slice(ax, ax + 1))
                        ),
                        bounds=(lo, hi),
                        method="bounded",
                        options={"xatol": 1e-7},
                    )
                    s[ax] = float(res.x)
        s = np.where(den > 0, s, [p.default for p in NOISE])  # no data on an axis: not identified
        return {**values, "noise_x_deg": float(s[0]), "noise_y_deg": float(s[1])}

    def log_likelihood(self, values: dict) -> float:
        pred, motor_var = self.predict(values), self.motor_variance(values)
        d = self.data
        m = d.measured
        if not np.all(np.isfinite(pred[m])):
            return -math.inf  # a flash lost by the read-out under these parameters
        resid = np.where(m, d.perceived_deg - pred, 0.0)
        sig = np.array([values["noise_x_deg"], values["noise_y_deg"]])
        return self._log_likelihood(sig, resid, motor_var, slice(0, 2))
