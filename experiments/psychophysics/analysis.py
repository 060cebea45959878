"""Summary of a flash-localization table: compression index and mean error direction.

Compression index (Morrone, Ross & Burr 1997; Kaiser & Lappe 2004): for one saccade amplitude
and one flash time, 1 - (spread of the perceived positions) / (spread of the true positions),
spread = RMS distance of the positions from their mean. 0: veridical layout; 1: all flashes
seen at one point. The per-amplitude summary gives the peak index, its time, the full width at
half maximum of the index-vs-time curve, and the mean error towards the target along the
saccade (x) and orthogonal to it (y), over flashes within +-50 ms of onset.
"""

from __future__ import annotations

import numpy as np

from .timecourse import RemapTimeCourse

__all__ = [
    "compression_index",
    "separation_compression",
    "displacement_psychometrics",
    "summary",
    "format_summary",
    "sampling_error",
]


def _spread(x: np.ndarray, y: np.ndarray) -> float:
    return float(np.sqrt(np.mean((x - x.mean()) ** 2 + (y - y.mean()) ** 2)))


def compression_index(table: dict[str, np.ndarray]) -> dict[float, tuple[np.ndarray, np.ndarray]]:
    """{amplitude: (flash times (ms), compression index)} from a trials table (columns)."""
    out = {}
    amp, t = table["saccade_amplitude_deg"], table["flash_time_ms"]
    for a in np.unique(amp):
        times = np.unique(t[amp == a])
        ci = []
        for s in times:
            m = (amp == a) & (t == s)
            ci.append(
                1
                - _spread(table["perceived_x_deg"][m], table["perceived_y_deg"][m])
                / _spread(table["true_x_deg"][m], table["true_y_deg"][m])
            )
        out[float(a)] = (times, np.array(ci))
    return out


def separation_compression(table: dict[str, np.ndarray]) -> dict[float, tuple[np.ndarray, np.ndarray]]:
    """{amplitude: (flash times (ms), 1 - mean perceived / mean true separation of the two flashes)}
    from a ``separation`` paradigm table: how much the distance between two simultaneous flashes
    shrinks, to compare with ``compression_index`` (how much their positions crowd together)."""
    out = {}
    amp, t = table["saccade_amplitude_deg"], table["flash_time_ms"]
    true = np.hypot(table["second_true_x_deg"] - table["true_x_deg"], table["second_true_y_deg"] - table["true_y_deg"])
    seen = np.hypot(
        table["second_perceived_x_deg"] - table["perceived_x_deg"],
        table["second_perceived_y_deg"] - table["perceived_y_deg"],
    )
    for a in np.unique(amp):
        times = np.unique(t[amp == a])
        out[float(a)] = (
            times,
            np.array([1 - seen[(amp == a) & (t == s)].mean() / true[(amp == a) & (t == s)].mean() for s in times]),
        )
    return out


def _probit_fit(x: np.ndarray, y: np.ndarray, start: tuple[float, float] | None = None) -> tuple[float, float]:
    """Maximum-likelihood cumulative Gaussian with 2 % lapses: (PSE, s.d.); from ``start`` alone
    when given (a bootstrap resample starts from the full data's fit)."""
    from scipy.optimize import minimize
    from scipy.special import ndtr  # scipy.stats.norm.cdf's own kernel, without its per-call checks

    def nll(theta):
        p = 0.01 + 0.98 * ndtr((x - theta[0]) / np.exp(theta[1]))
        return -np.sum(y * np.log(p) + (1 - y) * np.log(1 - p))

    span = max(float(np.ptp(x)), 1e-3)
    starts = [(m, s) for m in (float(np.median(x)), 0.0) for s in (0.25 * span, span)] if start is None else [start]
    best = min(
        (
            minimize(nll, [m, np.log(s)], method="Nelder-Mead", options={"xatol": 1e-3, "fatol": 1e-4})
            for m, s in starts
        ),
        key=lambda r: r.fun,
    )
    return float(best.x[0]), float(min(np.exp(best.x[1]), 1e3))


def _monotone_p(p: np.ndarray, n: np.ndarray) -> float:
    """P value of proportions ``p`` (counts ``n``) against the best non-decreasing ones."""
    from scipy.optimize import isotonic_regression
    from scipy.stats import chi2

    iso = isotonic_regression(p, weights=n).x
    pooled = len(p) - len(np.unique(np.round(iso, 12)))
    if pooled == 0:
        return 1.0
    k = p * n

    def ll(q):
        q = np.clip(q, 1e-12, 1 - 1e-12)
        return float(np.sum(k * np.log(q) + (n - k) * np.log(1 - q)))

    return float(chi2.sf(max(0.0, 2 * (ll(p) - ll(iso))), pooled))


def _no_reports(levels: np.ndarray, lost: int, n_boot: int) -> dict:
    """``displacement_psychometrics``' entry for a blank whose every trial lost the target: no
    proportions and no fit (NaN), ``monotonic`` False, ``monotone_p`` NaN."""
    nan = float("nan")
    r = {
        "lost": lost,
        "steps_deg": levels,
        "p_forward": np.full(len(levels), nan),
        "pse_deg": nan,
        "threshold_deg": nan,
        "monotonic": False,
        "monotone_p": nan,
    }
    if n_boot:
        r["pse_ci"] = r["threshold_ci"] = (nan, nan)
    return r


def displacement_psychometrics(
    table: dict[str, np.ndarray], n_boot: int = 0, seed: int = 0, start: dict | None = None
) -> dict[int, dict]:
    """Per blank duration (ms) of a ``displacement`` table: the proportion of "forward" reports per
    step and a cumulative-Gaussian fit by maximum likelihood (2 % lapses): ``pse_deg`` (the step
    seen as none) and ``threshold_deg`` (its s.d.: the step from 50 % to 84 % "forward"), and
    ``monotonic``: False when P("forward") falls between neighbouring steps by more than two
    binomial standard errors (a threshold is then not meaningful); ``lost``: trials without a report
    (the target lost after the saccade: ``reported_forward`` NaN), left out. With ``n_boot`` > 0, 95 %
    bootstrap CIs (``pse_ci``, ``threshold_ci``: reports resampled within each step). A blank with no
    report at all: NaN proportions, fit and CIs (``lost`` = its trials). ``start``:
    {blank: (pse, s.d.)} to start each fit from (one start instead of four)."""
    out = {}
    steps, blank, fwd = table["flash_dx_deg"], table["flash_time_ms"], table["reported_forward"]
    rng = np.random.default_rng(seed)
    for b in np.unique(blank):
        sel = (blank == b) & np.isfinite(fwd)  # no report where the target was lost (``lost``: how many)
        x, y = steps[sel], fwd[sel]
        if not sel.any():  # the target lost in every trial: nothing to fit (NaN, not a crash)
            out[int(b)] = _no_reports(np.unique(steps[blank == b]), int(np.sum(blank == b)), n_boot)
            continue
        pse, sd = _probit_fit(x, y, None if start is None else start.get(int(b)))
        levels = np.unique(x)
        p = np.array([y[x == v].mean() for v in levels])
        n = np.array([(x == v).sum() for v in levels])
        r = {
            "lost": int(np.sum((blank == b) & ~np.isfinite(fwd))),
            "steps_deg": levels,
            "p_forward": p,
            "pse_deg": pse,
            "threshold_deg": sd,
            "monotonic": bool(np.all(np.diff(p) >= 0)),
            "monotone_p": _monotone_p(p, n),
        }
        if n_boot:
            groups = [np.flatnonzero(x == v) for v in levels]
            boots = []
            for _ in range(n_boot):
                idx = np.concatenate([rng.choice(g, size=g.size, replace=True) for g in groups])
                boots.append(_probit_fit(x[idx], y[idx], (pse, sd)))
            boot = np.array(boots)
            r["pse_ci"] = tuple(np.percentile(boot[:, 0], [2.5, 97.5]))
            r["threshold_ci"] = tuple(np.percentile(boot[:, 1], [2.5, 97.5]))
        out[int(b)] = r
    return out


def _fwhm(times: np.ndarray, values: np.ndarray) -> float:
    """Width (ms) of the region where ``values`` exceed half their maximum (linear interpolation)."""
    if len(times) < 2 or not np.max(values) > 0:
        return float("nan")
    i = int(np.argmax(values))
    half = values[i] / 2

    def cross(rng):
        prev = i
        for j in rng:
            if values[j] < half:
                f = (values[prev] - half) / (values[prev] - values[j])
                return times[prev] + f * (times[j] - times[prev])
            prev = j
        return float("nan")

    return float(cross(range(i + 1, len(times))) - cross(range(i - 1, -1, -1)))


def summary(table: dict[str, np.ndarray], window_ms: float = 50.0) -> list[dict]:
    """One row per saccade amplitude: peak compression, time of peak, width, mean error direction."""
    rows = []
    ci = compression_index(table)
    amp, t = table["saccade_amplitude_deg"], table["flash_time_ms"]
    for a, (times, vals) in ci.items():
        i = int(np.argmax(vals))
        near = (amp == a) & (np.abs(t) <= window_ms)
        far = (amp == a) & (np.abs(t) >= 150)
        pre = (amp == a) & (t >= -100) & (t <= -25)
        rows.append(
            {
                "saccade_amplitude_deg": a,
                "peak_compression": float(vals[i]),
                "peak_time_ms": float(times[i]),
                "fwhm_ms": _fwhm(times, vals),
                "mean_toward_x_deg": float(np.mean(table["error_toward_x_deg"][near])) if near.any() else float("nan"),
                "mean_toward_y_deg": float(np.mean(table["error_toward_y_deg"][near])) if near.any() else float("nan"),
                "far_rms_error_deg": float(
                    np.sqrt(np.mean(table["error_x_deg"][far] ** 2 + table["error_y_deg"][far] ** 2))
                )
                if far.any()
                else float("nan"),
                # the uniform shift before the saccade, along it (the saccade goes to +x)
                "pre_shift_x_deg": float(np.mean(table["error_x_deg"][pre])) if pre.any() else float("nan"),
                "n_trials": int(np.sum(amp == a)),
            }
        )
    return rows


def sampling_error(table: dict[str, np.ndarray]) -> dict[str, float]:
    """Bias and RMS of the localization error (deg), for a table run with gain 0."""
    ex, ey = table["error_x_deg"], table["error_y_deg"]
    return {
        "bias_x_deg": float(ex.mean()),
        "bias_y_deg": float(ey.mean()),
        "rms_x_deg": float(np.sqrt(np.mean(ex**2))),
        "rms_y_deg": float(np.sqrt(np.mean(ey**2))),
        "max_deg": float(np.max(np.hypot(ex, ey))),
    }


def format_summary(
    rows: list[dict], timecourse: RemapTimeCourse | None = None, n_trials: int | None = None, config=None
) -> str:
    """A short text report of ``summary`` rows; ``config`` (a ``TrialConfig``) names the model and
    condition (and, for the paper model, its time course: ``timecourse`` alone does the same)."""
    lines = ["Perisaccadic flash localization (conformal camera, log-radius remapping, paper §6.5)"]
    if n_trials is not None:
        lines.append(f"trials: {n_trials}")
    if config is not None:
        lines.append(f"model: {config.model}, condition: {config.condition}, paradigm: {config.paradigm}")
        from .theories import theory

        model = theory(config.model)
        lines += model.describe(config)
        timecourse = config.timecourse if model.uses_timecourse else None
    if timecourse is not None:
        tc = timecourse
        lines.append(
            f"gain time course: peak {tc.peak_gain:.3f} (compression {1 - np.exp(-tc.peak_gain):.0%}) at "
            f"{tc.peak_time_ms:+.0f} ms, rise {tc.rise_ms:.0f} ms, decay {tc.decay_ms:.0f} ms"
        )
    lines.append(
        "amplitude  peak CI  at (ms)  FWHM (ms)  toward-target x / y (deg, |t|<=50 ms)  shift x (deg, -100..-25 ms)"
        "  rms error |t|>=150 ms"
    )
    for r in rows:
        lines.append(
            f"{r['saccade_amplitude_deg']:7.1f}    {r['peak_compression']:6.3f}  {r['peak_time_ms']:+7.0f}"
            f"  {r['fwhm_ms']:9.1f}  {r['mean_toward_x_deg']:+8.2f} / {r['mean_toward_y_deg']:+6.2f}"
            f"                    {r.get('pre_shift_x_deg', float('nan')):+6.2f}"
            f"                     {r['far_rms_error_deg']:6.2f}"
        )
    lines.append(
        "CI = 1 - perceived spread / true spread; toward-target > 0 means errors point at the target; "
        "shift x > 0: in the saccade's direction."
    )
    return "\n".join(lines) + "\n"
