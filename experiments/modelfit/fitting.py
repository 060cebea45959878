"""Maximum-likelihood fits, model comparison and simulated data sets.

``fit`` estimates a model's free parameters (``likelihood.FIT_MODELS``) by maximum likelihood
(scipy's Nelder-Mead on parameters mapped to their bounds by a logistic), with standard errors from
the numerical Hessian of the negative log-likelihood at the optimum (95 % Wald intervals, clipped
to the bounds; ``hessian_ok`` false and NaN intervals where it is not positive definite).
Every evaluation is appended to ``fit_log.csv``; a fit that is run again starts from the best
logged parameters and re-uses the cached observations, so an interrupted fit resumes.

``compare`` fits several models on the same observations and ranks them by AIC (BIC beside it),
with likelihood-ratio tests for nested pairs (``likelihood.NESTED``).
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
from pathlib import Path

import numpy as np

from .data import LocalizationData
from .likelihood import FIT_MODELS, NESTED, Evaluator, FitModel
from .observe import observe_trials

__all__ = ["fit", "compare", "simulate_data", "prepare", "IMAGE_SIZE"]

#: Eye image size of the fits' observations (px): the study's 256 px cost 4x the rendering.
IMAGE_SIZE = 128


def _model(name: str) -> FitModel:
    if name not in FIT_MODELS:
        raise ValueError(f"unknown model {name!r}; choose from {', '.join(FIT_MODELS)}")
    return FIT_MODELS[name]


def prepare(data: LocalizationData, out: Path | None, *, backend: str = "local", workers: int = 1,
            ray_address: str | None = None, image_size: int = IMAGE_SIZE):
    """The unique trials behind the data rows, observed once per condition: (runners, observations,
    row_trial)."""
    from ..psychophysics import Trial, TrialConfig, TrialRunner

    runners, observations = {}, {}
    row_trial = np.zeros(len(data), int)
    for cond in sorted(set(data.condition)):
        rows = np.flatnonzero(data.condition == cond)
        keys: dict = {}
        for r in rows:
            a = float(data.amplitude_deg[r])
            k = (a, int(data.flash_time_ms[r]), round(float(data.true_deg[r, 0]) - a / 2, 6),
                 round(float(data.true_deg[r, 1]), 6))
            row_trial[r] = keys.setdefault(k, len(keys))
        trials = [Trial(trial_id=i, amplitude_deg=k[0], flash_dx_deg=k[2], flash_dy_deg=k[3], flash_time_ms=k[1],
                        repetition=0, seed=0) for k, i in sorted(keys.items(), key=lambda kv: kv[1])]
        config = TrialConfig(image_size=image_size, condition=cond)
        observations[cond] = observe_trials(trials, config, None if out is None else out / "observations",
                                            backend=backend, workers=workers, ray_address=ray_address)
        runners[cond] = TrialRunner(config)
    return runners, observations, row_trial


def _to_z(model: FitModel, values: dict) -> np.ndarray:
    z = []
    for p in model.parameters:
        u = (values[p.name] - p.lo) / (p.hi - p.lo)
        u = min(max(u, 1e-6), 1 - 1e-6)
        z.append(math.log(u / (1 - u)))
    return np.array(z)


def _from_z(model: FitModel, z) -> dict:
    return {p.name: p.lo + (p.hi - p.lo) / (1 + math.exp(-float(v))) for p, v in zip(model.parameters, z)}


def _data_hash(data: LocalizationData) -> str:
    h = hashlib.sha256()
    for a in (data.amplitude_deg, data.flash_time_ms, data.true_deg, data.perceived_deg, data.n, data.sd_deg):
        h.update(np.ascontiguousarray(a, float).tobytes())
    h.update("|".join(data.condition).encode())
    return h.hexdigest()[:12]


def _quadratic_hessian(f, x: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """Hessian of ``f`` at ``x`` from a least-squares quadratic through f at x, x +- h_i, x +- 2 h_i
    and x +- h_i +- h_j: robust to the small steps in a likelihood read from rendered centroids."""
    k = len(x)
    pts = [np.zeros(k)]
    for i in range(k):
        for m in (-2, -1, 1, 2):
            pts.append(np.eye(k)[i] * m)
        for j in range(i + 1, k):
            for a in (-1, 1):
                for b in (-1, 1):
                    pts.append(np.eye(k)[i] * a + np.eye(k)[j] * b)
    pts = np.array(pts)
    vals = np.array([f(x + p * steps) for p in pts])
    iu = np.triu_indices(k)
    A = np.column_stack([np.ones(len(pts)), pts, np.array([np.outer(p, p)[iu] for p in pts])])
    coef = np.linalg.lstsq(A, vals, rcond=None)[0]
    Q = np.zeros((k, k))
    Q[iu] = coef[1 + k:]
    H = Q + Q.T  # d2/dp2 of sum_{i<=j} q_ij p_i p_j: 2 q_ii on the diagonal, q_ij off it
    return H / np.outer(steps, steps)


def _fit_prepared(model: FitModel, data, runners, observations, row_trial, out: Path | None, max_evals: int) -> dict:
    """Maximize the likelihood over the model's parameters with the report noise profiled out
    (its closed-form maximum for the others), Nelder-Mead from the best of a coarse grid."""
    import itertools

    from scipy.optimize import minimize

    ev = Evaluator(model, data, runners, observations, row_trial)
    free = [p for p in model.parameters if not p.name.startswith("noise")]
    sub = FitModel(model.name, model.config, tuple(free))
    names = [p.name for p in model.parameters]
    log_path = None if out is None else out / "fit_log.csv"
    tag = f"{model.name}|{_data_hash(data)}"
    start, best_logged = None, -math.inf
    if log_path is not None and log_path.exists():  # resume: start from the best logged parameters
        with log_path.open(newline="") as fh:
            for row in csv.DictReader(fh):
                try:
                    if row["fit"] == tag and float(row["log_likelihood"]) > best_logged:
                        best_logged, start = float(row["log_likelihood"]), {p.name: float(row[p.name]) for p in free}
                except (KeyError, ValueError, TypeError):
                    continue  # a torn last line of an interrupted fit
    fh = None
    if log_path is not None:
        new = not log_path.exists()
        fh = log_path.open("a", newline="")
        w = csv.writer(fh)
        if new:
            w.writerow(["fit", "log_likelihood"] + names)

    def profiled(values: dict) -> tuple[float, dict]:
        full = ev.noise_mle(values)
        ll = ev.log_likelihood(full)
        if fh is not None:
            w.writerow([tag, repr(ll)] + [repr(full[n]) for n in names])
            fh.flush()
        return (ll if math.isfinite(ll) else -1e12), full

    try:
        if start is None:  # the best of a coarse grid (the default and 2 more levels per parameter)
            grid = [[p.lo + f * (p.hi - p.lo) for f in (0.2, 0.6)] + [p.default] for p in free]
            start = max(({p.name: v for p, v in zip(free, combo)} for combo in itertools.product(*grid)),
                        key=lambda v: profiled(v)[0])
        res = minimize(lambda z: -profiled(_from_z(sub, z))[0], _to_z(sub, start), method="Nelder-Mead",
                       options={"maxfev": max_evals, "xatol": 1e-3, "fatol": 1e-2, "adaptive": True})
        ll, best = profiled(_from_z(sub, res.x))
        x = np.array([best[p.name] for p in free])
        span = np.array([p.hi - p.lo for p in free])
        room = np.minimum(x - [p.lo for p in free], [p.hi for p in free] - x)
        steps = np.maximum(np.minimum(0.01 * span, room / 2.5), 1e-4 * span)
        H = _quadratic_hessian(lambda v: -profiled(dict(zip([p.name for p in free], v)))[0], x, steps)
    finally:
        if fh is not None:
            fh.close()
    try:
        cov = np.linalg.inv(H)
        ok = bool(np.all(np.isfinite(cov)) and np.all(np.linalg.eigvalsh(0.5 * (H + H.T)) > 0))
    except np.linalg.LinAlgError:
        cov, ok = np.full_like(H, np.nan), False
    se = dict(zip([p.name for p in free], np.sqrt(np.diag(cov)) if ok else np.full(len(free), np.nan)))
    n_eff = len(data) + float(np.sum(np.where(np.isfinite(data.sd_deg[:, 0]), data.n - 1, 0)))
    for nm in ("noise_x_deg", "noise_y_deg"):  # the MLE of a Gaussian s.d.: SE = s / sqrt(2 N)
        se[nm] = best[nm] / math.sqrt(2 * n_eff)
    bounds = {p.name: (p.lo, p.hi) for p in model.parameters}
    ci = {n: ([max(bounds[n][0], best[n] - 1.96 * se[n]), min(bounds[n][1], best[n] + 1.96 * se[n])]
              if math.isfinite(se[n]) else [float("nan")] * 2) for n in names}
    k, n_obs = len(names), data.n_observations
    return {"model": model.name, "parameters": {n: float(best[n]) for n in names},
            "se": {n: float(se[n]) for n in names}, "ci": ci, "log_likelihood": ll,
            "aic": 2 * k - 2 * ll, "bic": k * math.log(n_obs) - 2 * ll, "n": n_obs, "n_parameters": k,
            "n_rows": len(data), "converged": bool(res.success), "evaluations": ev.evaluations,
            "hessian_ok": ok, "data": data.source, "data_hash": _data_hash(data),
            "_predict": ev.predict(best)}


def _write_fit(result: dict, data: LocalizationData, out: Path) -> None:
    pred = result.pop("_predict")
    tmp = out / "fit.json.tmp"
    tmp.write_text(json.dumps(result, indent=2, allow_nan=True) + "\n")
    tmp.replace(out / "fit.json")
    with (out / "fitted_trials.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["saccade_amplitude_deg", "flash_time_ms", "condition", "true_x_deg", "true_y_deg", "n",
                    "perceived_x_deg", "perceived_y_deg", "predicted_x_deg", "predicted_y_deg"])
        for i in range(len(data)):
            w.writerow([data.amplitude_deg[i], data.flash_time_ms[i], data.condition[i], *data.true_deg[i], data.n[i],
                        *data.perceived_deg[i], *pred[i]])
    _plot_fit(data, pred, result, out / "fit.png")


def _plot_fit(data: LocalizationData, pred: np.ndarray, result: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    conds = sorted(set(data.condition))
    err = data.perceived_deg[:, 0] - data.true_deg[:, 0]
    perr = pred[:, 0] - data.true_deg[:, 0]
    fig, ax = plt.subplots(1, len(conds), figsize=(5.5 * len(conds), 3.8), squeeze=False)
    for c, cond in zip(ax[0], conds):
        for amp in sorted(set(data.amplitude_deg)):
            sel = (data.condition == cond) & (data.amplitude_deg == amp)
            ts = np.unique(data.flash_time_ms[sel])
            m = [np.average(err[sel & (data.flash_time_ms == t)], weights=data.n[sel & (data.flash_time_ms == t)]) for t in ts]
            pm = [perr[sel & (data.flash_time_ms == t)].mean() for t in ts]
            line, = c.plot(ts, m, "o", label=f"data {amp:g}°")
            c.plot(ts, pm, "-", color=line.get_color(), label=f"model {amp:g}°")
        c.axhline(0, color="0.7", lw=0.8)
        c.set(title=f"{cond}: mean horizontal error", xlabel="flash time re onset (ms)", ylabel="deg")
        c.legend(fontsize=7)
    fig.suptitle(f"{result['model']}: log L = {result['log_likelihood']:.1f}, AIC {result['aic']:.1f}")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def fit(data: LocalizationData, model: str, out, *, backend: str = "local", workers: int = 1,
        ray_address: str | None = None, max_evals: int = 300, image_size: int = IMAGE_SIZE) -> dict:
    """Fit ``model`` to ``data``; writes ``out/fit.json``, ``fitted_trials.csv``, ``fit.png`` and
    ``fit_log.csv``; returns the fit.json content."""
    m = _model(model)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    runners, observations, row_trial = prepare(data, out, backend=backend, workers=workers, ray_address=ray_address,
                                               image_size=image_size)
    result = _fit_prepared(m, data, runners, observations, row_trial, out, max_evals)
    _write_fit(result, data, out)
    return result


def compare(data: LocalizationData, models: list[str], out, *, backend: str = "local", workers: int = 1,
            ray_address: str | None = None, max_evals: int = 300, image_size: int = IMAGE_SIZE) -> list[dict]:
    """Fit each of ``models`` (observations shared); writes ``out/comparison.csv`` (ranked by AIC),
    ``out/lrt.csv`` (nested pairs), each fit in ``out/<model>/`` and ``comparison.png``."""
    from scipy.stats import chi2

    ms = [_model(m) for m in models]
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    runners, observations, row_trial = prepare(data, out, backend=backend, workers=workers, ray_address=ray_address,
                                               image_size=image_size)
    fits = {}
    for m in ms:
        sub = out / m.name.replace("/", "_")
        sub.mkdir(exist_ok=True)
        r = _fit_prepared(m, data, runners, observations, row_trial, sub, max_evals)
        _write_fit(r, data, sub)
        fits[m.name] = r
    rows = sorted(({"model": k, "log_likelihood": r["log_likelihood"], "aic": r["aic"], "bic": r["bic"],
                    "n_parameters": r["n_parameters"], "n": r["n"]} for k, r in fits.items()), key=lambda r: r["aic"])
    for r in rows:
        r["delta_aic"] = r["aic"] - rows[0]["aic"]
        r["delta_bic"] = r["bic"] - min(x["bic"] for x in rows)
    with (out / "comparison.csv").open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    tests = []
    for restricted, (full, df, on_bound) in NESTED.items():
        if restricted in fits and full in fits:
            lr = max(0.0, 2 * (fits[full]["log_likelihood"] - fits[restricted]["log_likelihood"]))
            p = float(chi2.sf(lr, df)) * (0.5 if on_bound else 1.0)
            tests.append({"restricted": restricted, "full": full, "lr_statistic": lr, "df": df, "p_value": p})
    with (out / "lrt.csv").open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=["restricted", "full", "lr_statistic", "df", "p_value"])
        w.writeheader()
        w.writerows(tests)
    _plot_comparison(rows, out / "comparison.png")
    return rows


def _plot_comparison(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 0.5 + 0.5 * len(rows)))
    ax.barh([r["model"] for r in rows][::-1], [r["delta_aic"] for r in rows][::-1], color="C0")
    ax.set(xlabel="AIC - best AIC", title="model comparison (lower is better)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def simulate_data(model: str, values: dict, design, conditions=("references", "dark"), reports: int = 1,
                  seed: int = 0, out_csv=None, *, workers: int = 1, image_size: int = IMAGE_SIZE) -> LocalizationData:
    """A data set from ``model`` at parameter ``values`` (noise included): every trial of ``design``
    in each condition, ``reports`` noisy reports each (seeded). Written to ``out_csv`` if given."""
    m = _model(model)
    missing = [p.name for p in m.parameters if p.name not in values]
    if missing:
        raise ValueError(f"simulate_data: give every parameter of {model}: missing {', '.join(missing)}")
    from ..psychophysics import TrialConfig, TrialRunner

    rng = np.random.default_rng(seed)
    rows = []
    trials = list(design.trials())
    for cond in conditions:
        config = TrialConfig(image_size=image_size, condition=cond)
        obs = observe_trials(trials, config, None, workers=workers)
        runner = TrialRunner(config)
        cfg = m.trial_config(config, values)
        for o in obs:
            r = runner.readout(o, cfg)
            for _ in range(reports):
                rows.append((r["saccade_amplitude_deg"], r["flash_time_ms"], r["true_x_deg"], r["true_y_deg"],
                             r["perceived_x_deg"] + rng.normal(0, values["noise_x_deg"]),
                             r["perceived_y_deg"] + rng.normal(0, values["noise_y_deg"]), cond))
        runner.close()
    a = np.array([r[:6] for r in rows], float)
    data = LocalizationData(a[:, 0], a[:, 1].astype(int), a[:, 2:4], a[:, 4:6], np.array([r[6] for r in rows]),
                            np.ones(len(rows), int), np.full((len(rows), 2), np.nan), "simulated")
    if out_csv is not None:
        with open(out_csv, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["saccade_amplitude_deg", "flash_time_ms", "true_x_deg", "true_y_deg", "perceived_x_deg",
                        "perceived_y_deg", "condition"])
            for r in rows:
                w.writerow([f"{r[0]:g}", int(r[1]), f"{r[2]:.4f}", f"{r[3]:.4f}", f"{r[4]:.4f}", f"{r[5]:.4f}", r[6]])
    return data
