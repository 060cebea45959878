"""Maximum-likelihood fits, model comparison and simulated data sets.

``fit`` estimates a model's free parameters (``likelihood.FIT_MODELS``) by maximum likelihood
(scipy's Nelder-Mead on parameters mapped to their bounds by a logistic, from the best of the
defaults and 8 fixed Sobol' points), with standard errors from a quadratic fitted to the negative log-likelihood
around the optimum (95 % Wald intervals, clipped to the bounds; ``hessian_ok`` false and ``null``
intervals where it is not positive definite; a parameter on a bound of its range has no Wald
interval, ``null``, and is listed in ``at_bounds``).

A fit is a function of its data and options (``fit_key``: the model, a hash of the data, the
forward model's configuration, ``max_evals``). Every evaluation is appended to ``fit_log.csv``
(each row with the fit key and a CRC-32); a fit that is run again replays the same optimization,
reading the logged evaluations instead of computing them, so a fit resumed after ``kill -9`` ends
with the same ``fit.json`` as one that was never interrupted, and a finished fit run again is a
no-op that says so. A folder holding another fit is refused; one writer per folder (a lock).

A model that loses the flashes of some rows (no activity to read out, e.g. a flash outside the
field of view) at every starting point cannot be fitted: :class:`FitError` names the rows. Outputs
are strict JSON (undefined intervals are ``null``).

``compare`` fits several models on the same observations and ranks them by AIC (BIC beside it),
with likelihood-ratio tests for nested pairs (``likelihood.NESTED``).
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import sys
import zlib
from pathlib import Path

import numpy as np

from ..folders import save_figure
from .data import LocalizationData
from .forward import ForwardModel, forward_model
from .likelihood import FIT_MODELS, NESTED, Evaluator, FitModel
from .observe import observe_trials

__all__ = ["fit", "compare", "simulate_data", "prepare", "fit_key", "IMAGE_SIZE", "FitError", "FitFolderError"]

#: Eye image size (px) that ``simulate`` uses by default (recorded in its sidecar, so fits match).
IMAGE_SIZE = 128
#: Version of the fit procedure and its files: part of every fit key.
FIT_FORMAT = 3


class FitError(RuntimeError):
    """The model cannot be fitted to these data (rows whose flashes it loses at every start)."""


class FitFolderError(ValueError):
    """The output folder holds a fit of another model, data set or options."""


def _model(name: str) -> FitModel:
    if name not in FIT_MODELS:
        raise ValueError(f"unknown model {name!r}; choose from {', '.join(FIT_MODELS)}")
    return FIT_MODELS[name]


def _data_hash(data: LocalizationData) -> str:
    h = hashlib.sha256()
    for a in (data.amplitude_deg, data.flash_time_ms, data.true_deg, data.perceived_deg, data.n, data.sd_deg):
        h.update(np.ascontiguousarray(a, float).tobytes())
    h.update("|".join(data.condition).encode())
    return h.hexdigest()[:12]


def fit_key(model: str, data: LocalizationData, fwd: ForwardModel, max_evals: int) -> str:
    """16 hex digits naming a fit: what it fits (model, data, forward model) and how (``max_evals``)."""
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(fwd.offset_deg, float).tobytes())
    h.update(np.ascontiguousarray(fwd.seed, np.int64).tobytes())
    text = json.dumps(
        {
            "format": FIT_FORMAT,
            "model": model,
            "data": _data_hash(data),
            "trials": h.hexdigest(),
            "forward": fwd.fingerprint(),
            "max_evals": int(max_evals),
        },
        sort_keys=True,
    )
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def prepare(
    data: LocalizationData,
    out: Path | None,
    fwd: ForwardModel | None = None,
    *,
    backend: str = "local",
    workers: int = 1,
    ray_address: str | None = None,
    progress: bool = False,
):
    """The unique trials behind the data rows, observed once per condition under the forward model
    ``fwd`` (default: ``forward_model(data)``): (runners, observations, row_trial). ``row_trial`` is
    (R,): each row's trial; or (R, K) with ``fwd.motor_draws`` K: the row's design cell under each of
    its K landing errors (``forward.draw_seed``)."""
    from dataclasses import replace

    from ..psychophysics import Trial, TrialRunner
    from .forward import draw_seed

    fwd = fwd or forward_model(data)
    noisy = fwd.config.endpoint_noise > 0  # only then do trials differ by seed
    draws = fwd.motor_draws
    runners, observations = {}, {}
    row_trial = np.zeros((len(data), draws) if draws else len(data), int)
    for cond in sorted(set(data.condition)):
        rows = np.flatnonzero(data.condition == cond)
        keys: dict = {}
        for r in rows:
            cell = (
                float(data.amplitude_deg[r]),
                int(data.flash_time_ms[r]),
                round(float(fwd.offset_deg[r, 0]), 6),
                round(float(fwd.offset_deg[r, 1]), 6),
            )
            if draws:
                row_trial[r] = [keys.setdefault((*cell, draw_seed(*cell, k)), len(keys)) for k in range(draws)]
            else:
                row_trial[r] = keys.setdefault((*cell, int(fwd.seed[r]) if noisy else 0), len(keys))
        trials = [
            Trial(
                trial_id=i,
                amplitude_deg=k[0],
                flash_dx_deg=k[2],
                flash_dy_deg=k[3],
                flash_time_ms=k[1],
                repetition=0,
                seed=k[4],
            )
            for k, i in sorted(keys.items(), key=lambda kv: kv[1])
        ]
        config = replace(fwd.config, condition=cond)
        runners[cond] = TrialRunner(config)
        observations[cond] = observe_trials(
            trials,
            config,
            None if out is None else out / "observations",
            backend=backend,
            workers=workers,
            ray_address=ray_address,
            progress=progress,
            runner=runners[cond],
        )
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
    pts_a = np.array(pts)
    vals = np.array([f(x + p * steps) for p in pts_a])
    iu = np.triu_indices(k)
    A = np.column_stack([np.ones(len(pts_a)), pts_a, np.array([np.outer(p, p)[iu] for p in pts_a])])
    coef = np.linalg.lstsq(A, vals, rcond=None)[0]
    Q = np.zeros((k, k))
    Q[iu] = coef[1 + k :]
    H = Q + Q.T  # d2/dp2 of sum_{i<=j} q_ij p_i p_j: 2 q_ii on the diagonal, q_ij off it
    return H / np.outer(steps, steps)


# ---------------------------------------------------------------------------------------------- the log
_NOISE = ("noise_x_deg", "noise_y_deg")


class _Log:
    """``fit_log.csv``: one row per evaluation (``fit_key``, log-likelihood, the free parameters and
    the profiled noise, ``crc32`` of the row's text), read back as a memo of evaluations. Rows of
    another fit, torn or damaged rows are dropped (and the file rewritten without them)."""

    def __init__(self, path: Path | None, key: str, free: list[str]):
        self.path, self.key, self.free = path, key, free
        self.header = ["fit_key", "log_likelihood", *free, *_NOISE, "crc32"]
        self.memo: dict[tuple, tuple] = {}
        self.read: set[tuple] = set()  # the keys read from the file (an earlier run's evaluations)
        self.fh = None
        if path is None:
            return
        kept, dropped = [], 0
        if path.exists():
            lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
            if lines and lines[0].split(",") == self.header:
                for line in lines[1:]:
                    row = self._parse(line)
                    if row is None:
                        dropped += 1
                        continue
                    kept.append(line)
                    self.memo[row[0]] = row[1]
            elif lines:
                raise FitFolderError(
                    f"{path} is the log of another fit (its header differs); use another --out folder or delete it"
                )
        if dropped:
            print(
                f"{path}: dropped {dropped} torn, damaged or foreign row(s); those evaluations are redone",
                file=sys.stderr,
            )
        from ..folders import atomic_write_text

        atomic_write_text(path, "\n".join([",".join(self.header), *kept]) + "\n")
        self.read = set(self.memo)
        self.fh = path.open("a", encoding="utf-8")

    def _parse(self, line: str):
        body, sep, crc = line.rpartition(",")
        if not sep or f"{zlib.crc32(body.encode()):08x}" != crc:
            return None
        f = body.split(",")
        if len(f) != len(self.header) - 1 or f[0] != self.key:
            return None
        try:
            vals = [float(v) for v in f[1:]]
        except ValueError:
            return None
        k = len(self.free)
        return tuple(f[2 : 2 + k]), (vals[0], vals[1 + k], vals[2 + k])

    def add(self, key: tuple, ll: float, noise: tuple) -> None:
        self.memo[key] = (ll, *noise)
        if self.fh is not None:
            body = ",".join([self.key, repr(float(ll)), *key, *(repr(float(v)) for v in noise)])
            self.fh.write(f"{body},{zlib.crc32(body.encode()):08x}\n")
            self.fh.flush()

    def close(self) -> None:
        if self.fh is not None:
            self.fh.close()
            self.fh = None


# ---------------------------------------------------------------------------------------------- fit
def _lost_rows(data: LocalizationData, preds: list[np.ndarray]) -> np.ndarray:
    """Rows whose prediction is not finite under every one of ``preds``."""
    lost = np.ones(len(data), bool)
    for p in preds:
        lost &= ~np.isfinite(p).all(axis=1)
    return np.flatnonzero(lost)


def _rows_text(data: LocalizationData, rows: np.ndarray) -> str:
    shown = ", ".join(str(int(i) + 2) for i in rows[:10]) + (f" and {len(rows) - 10} more" if len(rows) > 10 else "")
    i = int(rows[0])
    return (
        f"{len(rows)} of {len(data)} rows ({shown}; row {i + 2}: amplitude {data.amplitude_deg[i]:g} deg, flash "
        f"at ({data.true_deg[i, 0]:g}, {data.true_deg[i, 1]:g}) deg, {data.flash_time_ms[i]} ms, "
        f"{data.condition[i]})"
    )


#: Starting points of a fit besides the defaults (a fixed scrambled Sobol' design: deterministic).
N_STARTS = 8


def _starts(free: list) -> list[dict]:
    """The defaults and ``N_STARTS`` points of a scrambled Sobol' sequence (seed 0) over the middle
    80 % of each free parameter's range: the same points on every run."""
    from scipy.stats import qmc

    u = qmc.Sobol(d=len(free), scramble=True, seed=0).random(N_STARTS)
    pts = [{p.name: p.default for p in free}]
    pts += [{p.name: p.lo + (0.1 + 0.8 * float(v)) * (p.hi - p.lo) for p, v in zip(free, row)} for row in u]
    return pts


def _fit_prepared(
    model: FitModel,
    data,
    runners,
    observations,
    row_trial,
    out: Path | None,
    max_evals: int,
    key: str = "",
    progress: bool = False,
) -> dict:
    """Maximize the likelihood over the model's parameters with the report noise profiled out
    (its closed-form maximum for the others): Nelder-Mead from the best of fixed starting points (``_starts``).
    Deterministic: the same data, model and options give the same evaluations in the same order."""
    from scipy.optimize import minimize

    ev = Evaluator(model, data, runners, observations, row_trial)
    free = [p for p in model.parameters if not p.name.startswith("noise")]
    free_names = [p.name for p in free]
    sub = FitModel(model.name, model.config, tuple(free))
    names = [p.name for p in model.parameters]
    log = _Log(None if out is None else out / "fit_log.csv", key, free_names)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(
            total=1 + N_STARTS + max_evals + 1 + 2 * len(free) ** 2 + 2 * len(free) + 1,
            unit="eval",
            desc=f"fitting {model.name}",
        )
    replayed = 0

    def profiled(values: dict) -> tuple[float, dict]:
        nonlocal replayed
        k = tuple(repr(float(values[n])) for n in free_names)
        hit = log.memo.get(k)
        if hit is not None:
            replayed += k in log.read  # a point this run evaluated before is no read-back
            ll, nx, ny = hit
            full = {**{n: float(v) for n, v in zip(free_names, k)}, "noise_x_deg": nx, "noise_y_deg": ny}
        else:
            full = ev.noise_mle(values)
            ll = ev.log_likelihood(full)
            log.add(k, ll, (full["noise_x_deg"], full["noise_y_deg"]))
        if bar is not None:
            bar.update(1)
        return ll, full

    def objective(values: dict) -> float:
        ll = profiled(values)[0]
        return ll if math.isfinite(ll) else -1e12  # a penalty the optimizer can compare, never an output

    try:
        starts = _starts(free)
        lls = [profiled(v)[0] for v in starts]
        if not any(math.isfinite(v) for v in lls):
            lost = _lost_rows(data, [ev.predict(v) for v in starts])
            lost = lost if lost.size else np.flatnonzero(~np.isfinite(ev.predict(starts[-1])).all(axis=1))
            raise FitError(
                f"{model.name} cannot be fitted: at every starting point it loses the flash of "
                f"{_rows_text(data, lost)} -- no activity to read out (a flash outside the eyes' field "
                "of view, or one the read-out's threshold drops); remove those rows or check their units"
            )
        start = starts[int(np.argmax([v if math.isfinite(v) else -np.inf for v in lls]))]
        res = minimize(
            lambda z: -objective(_from_z(sub, z)),
            _to_z(sub, start),
            method="Nelder-Mead",
            options={"maxfev": max_evals, "xatol": 1e-3, "fatol": 1e-2, "adaptive": True},
        )
        ll, best = profiled(_from_z(sub, res.x))
        x = np.array([best[n] for n in free_names])
        span = np.array([p.hi - p.lo for p in free])
        room = np.minimum(x - [p.lo for p in free], [p.hi for p in free] - x)
        steps = np.minimum(0.01 * span, room / 2.5)
        inner = np.flatnonzero(steps >= 1e-4 * span)  # room for x +- 2 steps inside the bounds
        H = np.full((len(free), len(free)), np.nan)
        if inner.size:  # parameters on a bound have no Wald interval; the others are profiled at x

            def at(v: np.ndarray) -> float:
                y = x.copy()
                y[inner] = v
                return -profiled(dict(zip(free_names, y)))[0]

            H[np.ix_(inner, inner)] = _quadratic_hessian(at, x[inner], steps[inner])
    finally:
        log.close()
        if bar is not None:
            bar.close()
    if replayed and progress:
        print(f"{model.name}: {replayed} evaluations read back from {log.path}", file=sys.stderr)
    if not math.isfinite(ll):  # pragma: no cover - the optimum is at least the best finite start
        raise FitError(f"{model.name}: the optimum has no finite likelihood")
    pred = ev.predict(best)
    lost = np.flatnonzero(~np.isfinite(pred).all(axis=1))
    if lost.size:  # pragma: no cover - a finite log-likelihood has finite predictions
        raise FitError(f"{model.name}: at the optimum the model loses the flash of {_rows_text(data, lost)}")
    Hi = H[np.ix_(inner, inner)]
    ok = bool(inner.size and np.all(np.isfinite(Hi)))
    var = np.full(len(free), np.nan)
    if ok:
        try:
            cov = np.linalg.inv(Hi)
            ok = bool(np.all(np.isfinite(cov)) and np.all(np.linalg.eigvalsh(0.5 * (Hi + Hi.T)) > 0))
            var[inner] = np.diag(cov)
        except np.linalg.LinAlgError:
            ok = False
    se = dict(zip(free_names, np.sqrt(var) if ok else np.full(len(free), np.nan)))
    n_eff = len(data) + float(np.sum(np.where(np.isfinite(data.sd_deg[:, 0]), data.n - 1, 0)))
    for j, nm in enumerate(_NOISE):  # the MLE of a Gaussian s.d.: SE = s / sqrt(2 N); none without data
        se[nm] = best[nm] / math.sqrt(2 * n_eff) if data.measured[:, j].any() else math.nan
    bounds = {p.name: (p.lo, p.hi) for p in model.parameters}
    ci = {
        n: (
            [max(bounds[n][0], best[n] - 1.96 * se[n]), min(bounds[n][1], best[n] + 1.96 * se[n])]
            if math.isfinite(se[n])
            else [None, None]
        )
        for n in names
    }
    at_bound = [
        n for n in names if min(best[n] - bounds[n][0], bounds[n][1] - best[n]) <= 1e-3 * (bounds[n][1] - bounds[n][0])
    ]
    # a parameter without data (noise_y_deg of 1-D data) is not counted
    k, n_obs = len(names) - int(not data.measured[:, 1].any()), data.n_observations
    m = data.measured
    resid = np.where(m, data.perceived_deg - pred, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        rms = np.sqrt(np.sum(data.n[:, None] * resid**2, axis=0) / np.sum(np.where(m, data.n[:, None], 0), axis=0))
    return {
        "model": model.name,
        "parameters": {n: float(best[n]) for n in names},
        "se": {n: (float(se[n]) if math.isfinite(se[n]) else None) for n in names},
        "ci": ci,
        "log_likelihood": float(ll),
        "aic": 2 * k - 2 * ll,
        "bic": k * math.log(n_obs) - 2 * ll,
        "n": n_obs,
        "n_parameters": k,
        "n_rows": len(data),
        "converged": bool(res.success),
        "evaluations": len(log.memo),
        "hessian_ok": ok,
        "at_bounds": at_bound,
        "residual_rms_deg": [float(v) if math.isfinite(v) else None for v in rms],
        "data": data.source,
        "data_hash": _data_hash(data),
        "fit_key": key,
        "_predict": pred,
    }


def _checksum(result: dict) -> str:
    body = {k: v for k, v in result.items() if k != "checksum"}
    return hashlib.sha256(json.dumps(body, sort_keys=True, allow_nan=False).encode()).hexdigest()[:16]


def finished_fit(out: Path, key: str) -> dict | None:
    """The verified ``fit.json`` of the fit ``key`` in ``out`` (with its other outputs present), or
    ``None`` when there is none or it is damaged; :class:`FitFolderError` if ``out`` holds another fit."""
    path = out / "fit.json"
    if not path.exists():
        return None
    try:
        result = json.loads(path.read_text(encoding="utf-8"))
        ok = isinstance(result, dict) and result.get("checksum") == _checksum(result)
    except (OSError, UnicodeDecodeError, ValueError, TypeError):
        ok = False
    if not ok:
        print(f"{path} is damaged (unreadable or its checksum fails); fitting again", file=sys.stderr)
        return None
    if result.get("fit_key") != key:
        raise FitFolderError(
            f"{out} holds a fit of another model, data set or options (fit_key "
            f"{result.get('fit_key')}; this fit: {key}); use another --out folder or delete it"
        )
    if not all((out / f).exists() for f in ("fitted_trials.csv", "fit.png")):
        return None
    return result


def _write_fit(result: dict, data: LocalizationData, out: Path, fwd: ForwardModel) -> dict:
    """Write ``fitted_trials.csv``, ``fit.png`` and last (marking the fit finished) ``fit.json``."""
    from ..folders import atomic_write_text, json_safe, write_json

    pred = result.pop("_predict")
    result["forward_model"] = {"source": fwd.source, "config": fwd.fingerprint()}
    result = json_safe(result)
    result["checksum"] = _checksum(result)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(
        [
            "saccade_amplitude_deg",
            "flash_time_ms",
            "condition",
            "true_x_deg",
            "true_y_deg",
            "n",
            "perceived_x_deg",
            "perceived_y_deg",
            "predicted_x_deg",
            "predicted_y_deg",
        ]
    )
    for i in range(len(data)):
        w.writerow(
            [
                data.amplitude_deg[i],
                data.flash_time_ms[i],
                data.condition[i],
                *data.true_deg[i],
                data.n[i],
                *data.perceived_deg[i],
                *pred[i],
            ]
        )
    atomic_write_text(out / "fitted_trials.csv", buf.getvalue())
    _plot_fit(data, pred, result, out / "fit.png")
    write_json(out / "fit.json", result)
    return result


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
            m = [
                np.average(err[sel & (data.flash_time_ms == t)], weights=data.n[sel & (data.flash_time_ms == t)])
                for t in ts
            ]
            pm = [perr[sel & (data.flash_time_ms == t)].mean() for t in ts]
            (line,) = c.plot(ts, m, "o", label=f"data {amp:g}°")
            c.plot(ts, pm, "-", color=line.get_color(), label=f"model {amp:g}°")
        c.axhline(0, color="0.7", lw=0.8)
        c.set(title=f"{cond}: mean horizontal error", xlabel="flash time re onset (ms)", ylabel="deg")
        c.legend(fontsize=7)
    fig.suptitle(f"{result['model']}: log L = {result['log_likelihood']:.1f}, AIC {result['aic']:.1f}")
    fig.tight_layout()
    save_figure(fig, path, dpi=100)


def fit(
    data: LocalizationData,
    model: str,
    out,
    *,
    backend: str = "local",
    workers: int = 1,
    ray_address: str | None = None,
    max_evals: int = 300,
    observing: dict | None = None,
    forward: ForwardModel | None = None,
    progress: bool = False,
) -> dict:
    """Fit ``model`` to ``data``; writes ``out/fit.json``, ``fitted_trials.csv``, ``fit.png`` and
    ``fit_log.csv``; returns the fit.json content (with ``already_done`` true when it was finished).

    ``observing``: ``forward.OBSERVING_OPTIONS`` overriding the data's sidecar (``forward_model``);
    ``forward``: the forward model itself, when the caller has made it (then ``observing`` is unused)."""
    from ..psychophysics.runner import folder_lock

    m = _model(model)
    fwd = forward or forward_model(data, observing)
    with folder_lock(out) as out:
        return _fit_in(
            m,
            data,
            fwd,
            out,
            out,
            max_evals,
            progress,
            dict(backend=backend, workers=workers, ray_address=ray_address, progress=progress),
        )


def _fit_in(
    m, data, fwd, out: Path, root: Path, max_evals: int, progress: bool, options: dict, prepared: list | None = None
) -> dict:
    prepared = [] if prepared is None else prepared
    key = fit_key(m.name, data, fwd, max_evals)
    done = finished_fit(out, key)
    if done is not None:
        print(f"{m.name}: already fitted in {out} (fit_key {key}): nothing to do", file=sys.stderr)
        return {**done, "already_done": True}
    if not prepared:
        prepared.append(prepare(data, root, fwd, **options))
    runners, observations, row_trial = prepared[0]
    r = _fit_prepared(m, data, runners, observations, row_trial, out, max_evals, key, progress)
    return {**_write_fit(r, data, out, fwd), "already_done": False}


def compare(
    data: LocalizationData,
    models: list[str],
    out,
    *,
    backend: str = "local",
    workers: int = 1,
    ray_address: str | None = None,
    max_evals: int = 300,
    observing: dict | None = None,
    forward: ForwardModel | None = None,
    progress: bool = False,
) -> list[dict]:
    """Fit each of ``models`` (observations shared; each fit a no-op when finished); writes
    ``out/comparison.csv`` (ranked by AIC), ``out/lrt.csv`` (nested pairs), each fit in
    ``out/<model>/`` and ``comparison.png``. ``observing``, ``forward``: as for :func:`fit`."""
    from scipy.stats import chi2

    from ..folders import write_csv
    from ..psychophysics.runner import folder_lock

    ms = [_model(m) for m in models]
    dup = sorted({m.name for m in ms if [x.name for x in ms].count(m.name) > 1})
    if dup:
        raise ValueError(f"models listed twice: {', '.join(dup)}")
    fwd = forward or forward_model(data, observing)
    options = dict(backend=backend, workers=workers, ray_address=ray_address, progress=progress)
    fits: dict[str, dict] = {}
    prepared: list = []
    with folder_lock(out) as out:
        for m in ms:
            sub = out / m.name.replace("/", "_")
            with folder_lock(sub):
                fits[m.name] = _fit_in(m, data, fwd, sub, out, max_evals, progress, options, prepared)
        rows = sorted(
            (
                {
                    "model": k,
                    "log_likelihood": r["log_likelihood"],
                    "aic": r["aic"],
                    "bic": r["bic"],
                    "n_parameters": r["n_parameters"],
                    "n": r["n"],
                }
                for k, r in fits.items()
            ),
            key=lambda r: r["aic"],
        )
        for r in rows:
            r["delta_aic"] = r["aic"] - rows[0]["aic"]
            r["delta_bic"] = r["bic"] - min(x["bic"] for x in rows)
        write_csv(out / "comparison.csv", list(rows[0]), rows)
        tests = []
        for restricted, (full, df, on_bound) in NESTED.items():
            if restricted in fits and full in fits:
                lr = max(0.0, 2 * (fits[full]["log_likelihood"] - fits[restricted]["log_likelihood"]))
                p = float(chi2.sf(lr, df)) * (0.5 if on_bound else 1.0)
                tests.append({"restricted": restricted, "full": full, "lr_statistic": lr, "df": df, "p_value": p})
        write_csv(out / "lrt.csv", ["restricted", "full", "lr_statistic", "df", "p_value"], tests)
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
    save_figure(fig, path, dpi=100)


SIMULATED_COLUMNS = (
    "saccade_amplitude_deg",
    "flash_time_ms",
    "true_x_deg",
    "true_y_deg",
    "perceived_x_deg",
    "perceived_y_deg",
    "condition",
    "seed",
    "flash_dx_deg",
    "flash_dy_deg",
)


def simulate_data(
    model: str,
    values: dict,
    design,
    conditions=("references", "dark"),
    reports: int = 1,
    seed: int = 0,
    out_csv=None,
    *,
    workers: int = 1,
    image_size: int = IMAGE_SIZE,
    config=None,
    progress: bool = False,
    meta: dict | None = None,
    backend: str = "local",
    ray_address: str | None = None,
) -> LocalizationData:
    """A data set from ``model`` at parameter ``values`` (noise included): every trial of ``design``
    in each condition, ``reports`` noisy reports each (seeded); observed on ``workers`` processes or
    Ray actors (``backend``).

    ``config``: the observing ``TrialConfig`` (default: the defaults at ``image_size`` px). Written
    to ``out_csv`` if given (atomically; columns ``SIMULATED_COLUMNS``), with a sidecar
    ``out_csv.with_suffix(".json")`` holding ``meta``, the parameters, the design and the
    configuration that ``fit`` reads to reproduce the forward model."""
    from dataclasses import replace

    from ..psychophysics import TrialConfig, TrialRunner, config_fingerprint

    m = _model(model)
    missing = [p.name for p in m.parameters if p.name not in values]
    if missing:
        raise ValueError(f"simulate_data: give every parameter of {model}: missing {', '.join(missing)}")
    base = config if config is not None else TrialConfig(image_size=image_size)
    rng = np.random.default_rng(seed)
    rows = []
    trials = list(design.trials())
    for cond in conditions:
        cfg0 = replace(base, condition=cond)
        obs = observe_trials(
            trials, cfg0, None, workers=workers, progress=progress, backend=backend, ray_address=ray_address
        )
        runner = TrialRunner(cfg0)
        cfg = m.trial_config(cfg0, values)
        try:
            for t, o in zip(trials, obs):
                r = runner.readout(o, cfg)
                if not (math.isfinite(r["perceived_x_deg"]) and math.isfinite(r["perceived_y_deg"])):
                    raise FitError(
                        f"{model} loses the flash of trial {t.trial_id} ({cond}: amplitude "
                        f"{t.amplitude_deg:g} deg, offset ({t.flash_dx_deg:g}, {t.flash_dy_deg:g}) deg, "
                        f"{t.flash_time_ms} ms) at these parameters: no report can be simulated"
                    )
                for _ in range(reports):
                    rows.append(
                        (
                            r["saccade_amplitude_deg"],
                            r["flash_time_ms"],
                            r["true_x_deg"],
                            r["true_y_deg"],
                            r["perceived_x_deg"] + rng.normal(0, values["noise_x_deg"]),
                            r["perceived_y_deg"] + rng.normal(0, values["noise_y_deg"]),
                            cond,
                            t.seed,
                            t.flash_dx_deg,
                            t.flash_dy_deg,
                        )
                    )
        finally:
            runner.close()
    a = np.array([r[:6] for r in rows], float)
    data = LocalizationData(
        a[:, 0],
        a[:, 1].astype(int),
        a[:, 2:4],
        a[:, 4:6],
        np.array([r[6] for r in rows]),
        np.ones(len(rows), int),
        np.full((len(rows), 2), np.nan),
        str(out_csv) if out_csv is not None else "simulated",
    )
    if out_csv is not None:
        from ..folders import atomic_write_text, json_safe, write_json

        out_csv = Path(out_csv)
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(SIMULATED_COLUMNS)
        for r in rows:
            w.writerow(
                [
                    f"{r[0]:g}",
                    int(r[1]),
                    *(f"{round(v, 9) + 0.0:.10g}" for v in r[2:6]),
                    r[6],
                    int(r[7]),
                    f"{r[8]:g}",
                    f"{r[9]:g}",
                ]
            )
        fp = config_fingerprint(design, m.trial_config(base, values))
        fp["config"].pop("condition", None)
        side = {
            **(meta or {}),
            "generated_by": "python -m experiments simulate",
            "model": model,
            "parameters": dict(values),
            "design": fp["design"],
            "conditions": list(conditions),
            "reports_per_trial": reports,
            "seed": seed,
            "rows": len(rows),
            "config": fp["config"],
        }
        write_json(out_csv.with_suffix(".json"), json_safe(side))
        atomic_write_text(out_csv, buf.getvalue())
    return data
