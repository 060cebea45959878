"""``python -m experiments crossval``: which theory generalises from the conditions it was fitted on?

Cross-validation by condition (Wilson & Collins 2019, eLife 8:e49547, rule 9): for every data set,
each theory is fitted by maximum likelihood (``fitting``'s optimizer and resume, report noise
profiled) on one *fit set* and predicts *held-out* conditions with those parameters (``HELDOUT``):
fitted on ``references``, it predicts ``dark`` and ``marker`` (Zimmermann, Morrone & Burr 2014's
design, ``phenomena.MARKER``) and ``separation`` (two flashes 4 deg apart at once, each reported: the
design's flash and one ``SEPARATION_DEG`` beside it); fitted on the error along the saccade alone
(``references (x)``, 1-D data), it predicts the error across it (``references (y)``). The training
set is scored too (role ``training``), and ``displacement`` (Deubel, Schneider & Bridgeman 1996: the
target steps during the saccade, blanked 0 or 250 ms; a forward/backward report) is predicted as the
probability of "forward", ``Phi(perceived step / the theory's report s.d.)``, each report scored by its
Bernoulli log-likelihood (no RMSE). Neither separation nor displacement is ever fitted: ``fit``
models one position report of one flash, and ``forward_model`` refuses both.

**Data.** No condition-level published data set is in the repository
(``experiments/data/published/README.md``), so the data are *simulated observers*: each
generating theory (``--data-from``) reads out the design's trials observed with saccade motor
noise (5 % of the amplitude), plus Gaussian report noise (``--noise-deg``); the fitted theories
observe the trials without that motor noise. Data files are in ``fit``'s format.

**Outputs**: ``crossval.csv`` (``COLUMNS``: ``loglik_per_report`` and ``rmse_deg`` with bootstrap
CIs over trials), ``crossval_pairs.csv`` (best theory minus runner-up, paired bootstrap),
``crossval.png``, ``summary.txt``. The folder keeps ``run``'s promises (lock, atomic writes,
resume after ``kill -9`` to the same table, ``crossval.json`` refusing another configuration).
Every column, the assumptions and the measured table: docs/psychophysics/crossval.md.

Exit status: 0 done; 1 a theory cannot be fitted, the folder is in use, or an I/O error; 2 a
usage error; 130 / 143 interrupted (run the same command again to resume)."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from ..folders import save_figure

__all__ = [
    "crossvalidate",
    "markdown_table",
    "CrossvalFolderError",
    "THEORIES",
    "HELDOUT",
    "COLUMNS",
    "CONDITIONS",
    "MOTOR_NOISE",
    "PAIR_COLUMNS",
    "paired_difference",
    "score",
    "score_binary",
    "DISPLACEMENT_STEPS_DEG",
    "DISPLACEMENT_BLANKS_MS",
]

#: The theories fitted, and by default the ones that generate the data.
THEORIES = ("observer", "population", "paper", "mechanistic")
MOTOR_NOISE = 0.05  # saccade endpoint s.d., fraction of amplitude (van Beers 2007: ~5-10 %), as recovery
N_BOOT = 1000
#: Version of the folder's files: part of the configuration key (2: the separation and displacement
#: conditions).
FORMAT = 2


def _marker() -> tuple[float, float]:
    from ..psychophysics.phenomena import MARKER

    return MARKER


def conditions() -> dict[str, dict]:
    """Condition name -> ``TrialConfig`` overrides (the observing configuration of its trials)."""
    return {
        "references": dict(condition="references"),
        "dark": dict(condition="dark"),
        "marker": dict(condition="references", target_off_ms=0, markers=(_marker(),), ruler=False),
        "separation": dict(condition="references", paradigm="separation"),
    }


CONDITIONS = ("references", "dark", "marker", "separation")
#: The displacement held-out condition's design: steps (deg along the saccade) x blanks (ms) x repetitions
#: (each repetition its own landing error and report noise); ``phenomena``'s quick grid (``--quick``:
#: every other step, 2 repetitions).
DISPLACEMENT_STEPS_DEG = (-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0)
DISPLACEMENT_BLANKS_MS = (0, 250)
#: fit set -> (the condition it is fitted on, axes fitted (0 = x, 1 = y), [(held-out name, condition, axes)])
HELDOUT: dict[str, tuple[str, tuple[int, ...], list[tuple[str, str, tuple[int, ...]]]]] = {
    "references": (
        "references",
        (0, 1),
        [
            ("dark", "dark", (0, 1)),
            ("marker", "marker", (0, 1)),
            ("separation", "separation", (0, 1)),
            ("displacement", "displacement", ()),
        ],
    ),
    "references (x)": ("references", (0,), [("references (y)", "references", (1,))]),
}
COLUMNS = ["data", "theory", "fit_set", "condition", "role", "metric", "value", "ci_low", "ci_high", "n", "lost"]
#: ``crossval_pairs.csv``: per data set and held-out condition, the best theory against the runner-up.
PAIR_COLUMNS = [
    "data",
    "fit_set",
    "condition",
    "best",
    "runner_up",
    "delta_loglik_per_report",
    "ci_low",
    "ci_high",
    "n",
    "separated",
]


class CrossvalFolderError(ValueError):
    """The output folder holds a cross-validation of another configuration."""


def _design(quick: bool, seed: int):
    from ..psychophysics import MORRONE_OFFSETS_DEG, Design

    if quick:  # 4 positions on both sides of the target, above and below its row; 4 times
        return Design(
            amplitudes_deg=(20.0,),
            flash_offsets_deg=MORRONE_OFFSETS_DEG[1::2],
            flash_times_ms=(-150, -25, 0, 50),
            seed=seed,
            name="crossval-quick",
        )
    return Design(
        amplitudes_deg=(20.0,),
        flash_offsets_deg=MORRONE_OFFSETS_DEG,
        flash_times_ms=(-150, -100, -50, -25, 0, 25, 50, 100),
        seed=seed,
        name="crossval",
    )


def settings(
    *,
    quick: bool = False,
    seed: int = 0,
    theories=THEORIES,
    data_from=None,
    reports: int | None = None,
    noise_deg: float = 1.5,
    image_size: int | None = None,
    max_evals: int | None = None,
) -> dict:
    """The configuration of a cross-validation (what the folder's key is made of), defaults filled in."""
    from ..psychophysics.bounds import LIMITS
    from .likelihood import FIT_MODELS

    theories = list(theories)
    data_from = list(data_from) if data_from is not None else (["observer", "paper"] if quick else list(theories))
    for name in theories + data_from:
        if name not in FIT_MODELS:
            raise ValueError(f"unknown theory {name!r}; choose from {', '.join(FIT_MODELS)}")
    for what, names in (("theories", theories), ("data_from", data_from)):
        if not names:
            raise ValueError(f"{what}: name at least one theory")
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"{what}: {dup[0]} is listed twice; list each once")
    lim = LIMITS["noise_deg"]
    if not (isinstance(noise_deg, (int, float)) and lim.contains(noise_deg)):
        raise ValueError(f"noise_deg must be a number in {lim.text()}; got {noise_deg!r}")
    return {
        "format": FORMAT,
        "quick": bool(quick),
        "seed": int(seed),
        "theories": theories,
        "data_from": data_from,
        "reports": int(reports if reports is not None else 2),
        "noise_deg": float(noise_deg),
        "image_size": int(image_size if image_size is not None else (64 if quick else 128)),
        "max_evals": int(max_evals if max_evals is not None else (15 if quick else 120)),
        "motor_noise": MOTOR_NOISE,
    }


def _key(cfg: dict) -> str:
    return hashlib.sha256(json.dumps(cfg, sort_keys=True).encode()).hexdigest()[:16]


def _claim_folder(out: Path, cfg: dict) -> None:
    """Write ``crossval.json`` (the configuration and its key), or check that the folder's is this one."""
    from ..folders import write_json

    path = out / "crossval.json"
    key = _key(cfg)
    if path.exists():
        try:
            held = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, ValueError):
            held = None
        if not isinstance(held, dict) or held.get("key") != _key(held.get("settings", {})):
            raise CrossvalFolderError(
                f"{path} is damaged (unreadable or its key does not match its settings); "
                "delete it or use another --out folder"
            )
        if held["key"] != key:
            diff = sorted(k for k in set(cfg) | set(held["settings"]) if cfg.get(k) != held["settings"].get(k))
            raise CrossvalFolderError(
                f"{out} holds a cross-validation of another configuration (it differs in "
                f"{', '.join(diff)}); use another --out folder or delete it"
            )
        return
    write_json(path, {"generated_by": "python -m experiments crossval", "key": key, "settings": cfg})


# ---------------------------------------------------------------------------------------------- data
@dataclasses.dataclass
class _Condition:
    """A condition's trials, observed twice: with motor noise (the data) and without (the fits)."""

    name: str
    config: Any  # the fits' TrialConfig
    trials: list
    observations: list  # without motor noise, one per trial (seeds 0)
    runner: Any  # the fits' TrialRunner


def _flash_prefixes(config) -> tuple[str, ...]:
    """The read-out columns' prefixes of a trial's flashes: the flash, and in the separation paradigm
    the second one (``second_``)."""
    return ("", "second_") if config.paradigm == "separation" else ("",)


def _observe(name: str, design, cfg: dict, out: Path, options: dict) -> tuple[_Condition, list, Any]:
    from ..psychophysics import TrialConfig, TrialRunner
    from .observe import observe_trials

    over = conditions()[name]
    base = TrialConfig(image_size=cfg["image_size"], endpoint_noise=0.0, **over)
    noisy = dataclasses.replace(base, endpoint_noise=cfg["motor_noise"])
    trials = list(design.trials())
    clean = [dataclasses.replace(t, seed=0) for t in trials]
    runner, noisy_runner = TrialRunner(base), TrialRunner(noisy)
    obs = observe_trials(clean, base, out / "observations", runner=runner, **options)
    noisy_obs = observe_trials(trials, noisy, out / "observations", runner=noisy_runner, **options)
    return _Condition(name, base, trials, obs, runner), noisy_obs, noisy_runner


def _simulate(gen: str, cond: _Condition, noisy_obs: list, noisy_runner, cfg: dict, g: int, c: int) -> np.ndarray:
    """Rows (amplitude, time, true x, true y, perceived x, perceived y, trial index, seed, flash) of
    ``gen``'s reports in ``cond``: its read-out of the noisy observations plus report noise (seeded by
    the data set and the condition, so the order of work does not matter); ``flash`` 0, or 1 for the
    second flash of the separation paradigm (each report of a trial gives both, each with its noise)."""
    from .fitting import FitError
    from .likelihood import FIT_MODELS

    m = FIT_MODELS[gen]
    values = {p.name: p.default for p in m.parameters}
    rcfg = m.trial_config(noisy_runner.config, values)
    rng = np.random.default_rng([cfg["seed"], g, c])
    prefixes = _flash_prefixes(cond.config)
    rows = []
    for k, (t, o) in enumerate(zip(cond.trials, noisy_obs)):
        r = noisy_runner.readout(o, rcfg)
        for f, pre in enumerate(prefixes):
            if not (math.isfinite(r[f"{pre}perceived_x_deg"]) and math.isfinite(r[f"{pre}perceived_y_deg"])):
                raise FitError(
                    f"{gen} loses {'the second' if f else 'the'} flash of trial {t.trial_id} ({cond.name}: offset "
                    f"({t.flash_dx_deg:g}, {t.flash_dy_deg:g}) deg, {t.flash_time_ms} ms): no report can be simulated"
                )
        for _ in range(cfg["reports"]):
            for f, pre in enumerate(prefixes):
                rows.append(
                    (
                        r["saccade_amplitude_deg"],
                        r["flash_time_ms"],
                        r[f"{pre}true_x_deg"],
                        r[f"{pre}true_y_deg"],
                        r[f"{pre}perceived_x_deg"] + rng.normal(0, cfg["noise_deg"]),
                        r[f"{pre}perceived_y_deg"] + rng.normal(0, cfg["noise_deg"]),
                        k,
                        t.seed,
                        f,
                    )
                )
    return np.array(rows, float)


def _write_data(path: Path, rows: np.ndarray, cond: _Condition, design, gen: str, cfg: dict) -> None:
    """``rows`` in ``fit``'s format (``simulate``'s columns), with the sidecar ``fit`` reads; separation
    data add ``paradigm`` and ``flash`` (0 the design's flash, 1 the one beside it), which ``fit``
    refuses by name (it models one flash per trial)."""
    import csv
    import io

    from ..folders import atomic_write_text, write_json
    from ..psychophysics import config_fingerprint
    from ..psychophysics.trial import SEPARATION_DEG
    from .fitting import SIMULATED_COLUMNS

    two = cond.config.paradigm == "separation"
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(SIMULATED_COLUMNS + (("paradigm", "flash") if two else ()))
    label = cond.config.condition
    for r in rows:
        t = cond.trials[int(r[6])]
        f = int(r[8])
        w.writerow(
            [
                f"{r[0]:g}",
                int(r[1]),
                *(f"{round(v, 9) + 0.0:.10g}" for v in r[2:6]),
                label,
                int(r[7]),
                f"{t.flash_dx_deg + f * SEPARATION_DEG[0]:g}",
                f"{t.flash_dy_deg + f * SEPARATION_DEG[1]:g}",
            ]
            + (["separation", f] if two else [])
        )
    fp = config_fingerprint(design, dataclasses.replace(cond.config, endpoint_noise=cfg["motor_noise"]))
    fp["config"].pop("condition", None)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json(
        path.with_suffix(".json"),
        {
            "generated_by": "python -m experiments crossval",
            "model": gen,
            "crossval_condition": cond.name,
            "note": "a simulated observer: the generating theory at its defaults, motor and report noise",
            "report_noise_deg": cfg["noise_deg"],
            "reports_per_trial": cfg["reports"],
            "seed": cfg["seed"],
            "design": fp["design"],
            "conditions": [label],
            "rows": len(rows),
            "config": fp["config"],
        },
    )
    atomic_write_text(path, buf.getvalue())


def _localization(rows: np.ndarray, label: str, axes: tuple, source: str):
    from .data import LocalizationData

    perceived = rows[:, 4:6].copy()
    if 1 not in axes:
        perceived[:, 1] = np.nan
    return LocalizationData(
        rows[:, 0],
        rows[:, 1].astype(int),
        rows[:, 2:4],
        perceived,
        np.array([label] * len(rows)),
        np.ones(len(rows), int),
        np.full((len(rows), 2), np.nan),
        source,
    )


# ---------------------------------------------------------------------------------------------- displacement
def _displacement_steps(quick: bool) -> tuple[float, ...]:
    return DISPLACEMENT_STEPS_DEG[::2] if quick else DISPLACEMENT_STEPS_DEG


def _displacement_design(quick: bool, seed: int):
    from ..psychophysics import Design

    return Design(
        amplitudes_deg=(20.0,),
        flash_offsets_deg=tuple((s, 0.0) for s in _displacement_steps(quick)),
        flash_times_ms=DISPLACEMENT_BLANKS_MS,
        repetitions=2 if quick else 8,
        seed=seed,
        name="crossval-displacement",
    )


def _displacement_cells(quick: bool) -> list[tuple[float, int]]:
    """The (step, blank) cells of the displacement design, in the order of the predictions' rows."""
    return [(s, b) for s in _displacement_steps(quick) for b in DISPLACEMENT_BLANKS_MS]


def _displacement_config(theory: str, params: dict, cfg: dict, motor_noise: float):
    """The displacement paradigm's ``TrialConfig`` read out by ``theory`` at ``params`` (as ``phenomena``:
    20 deg saccades in the dark)."""
    from ..psychophysics import TrialConfig
    from .likelihood import FIT_MODELS

    base = TrialConfig(
        image_size=cfg["image_size"], condition="dark", paradigm="displacement", endpoint_noise=motor_noise
    )
    return FIT_MODELS[theory].trial_config(base, params)


def _simulate_displacement(gen: str, design, cfg: dict, bar=None) -> np.ndarray:
    """Rows (amplitude, blank ms, step deg, reported forward (0/1), cell index, seed) of ``gen``'s
    displacement reports: one per trial, each with its own landing error and report noise (the trial's
    seed), read out by ``gen`` at its defaults; a trial whose target ``gen`` loses gives no report
    (no row). ``bar``: a progress bar advanced by one per trial."""
    from ..psychophysics import TrialRunner
    from .likelihood import FIT_MODELS

    values = {p.name: p.default for p in FIT_MODELS[gen].parameters}
    runner = TrialRunner(_displacement_config(gen, values, cfg, cfg["motor_noise"]))
    cells = {c: k for k, c in enumerate(_displacement_cells(cfg["quick"]))}
    rows = []
    try:
        for t in design.trials():
            r = runner.run(t)
            if bar is not None:
                bar.update(1)
            if not math.isfinite(r["reported_forward"]):
                continue
            rows.append(
                (
                    t.amplitude_deg,
                    t.flash_time_ms,
                    t.flash_dx_deg,
                    r["reported_forward"],
                    cells[t.flash_dx_deg, t.flash_time_ms],
                    t.seed,
                )
            )
    finally:
        runner.close()
    return np.array(rows, float)


def _predict_displacement(theory: str, params: dict, cfg: dict) -> np.ndarray:
    """(cells, 2): log P(forward) and log P(backward) of each (step, blank) cell under ``theory`` at
    ``params``, without motor noise: ``Phi(+-perceived step / report s.d.)`` (the theory's own s.d.
    where it has one, ``TrialRunner.last``)."""
    from scipy.stats import norm

    from ..psychophysics import Trial, TrialRunner

    runner = TrialRunner(_displacement_config(theory, params, cfg, 0.0))
    out = []
    try:
        for k, (step, blank) in enumerate(_displacement_cells(cfg["quick"])):
            r = runner.run(Trial(k, 20.0, step, 0.0, blank, 0, 0))
            z = float(r["perceived_step_deg"]) / float(runner.last["report_sd_deg"])
            out.append((norm.logcdf(z), norm.logcdf(-z)))
    finally:
        runner.close()
    return np.array(out, float)


def score_binary(rows: np.ndarray, logp: np.ndarray, rng) -> dict:
    """``score`` for forward/backward reports: ``rows`` (``_simulate_displacement``'s: report in column
    3, cell in column 4) against each cell's (log P(forward), log P(backward)) ``logp``. Log-likelihood
    per report (Bernoulli) with a percentile bootstrap over reports (each its own trial); no RMSE.
    Reports in a cell whose target the theory loses (NaN) are left out and counted (``lost``)."""
    cell_all = rows[:, 4].astype(int)
    ok = np.isfinite(logp[cell_all]).all(axis=1)
    keys = np.flatnonzero(ok)
    fwd, cell = rows[ok, 3] > 0.5, cell_all[ok]
    ll = np.where(fwd, logp[cell, 0], logp[cell, 1])
    if not len(ll):
        return {
            "n": 0,
            "lost": int(np.sum(~ok)),
            "loglik_per_report": (math.nan,) * 3,
            "rmse_deg": (math.nan,) * 3,
            "per_trial": {},
        }
    point = float(ll.mean())
    draws = rng.integers(0, len(ll), size=(N_BOOT, len(ll)))
    lo, hi = np.percentile(ll[draws].mean(axis=1), [2.5, 97.5])
    return {
        "n": int(len(ll)),
        "lost": int(np.sum(~ok)),
        "loglik_per_report": (point, float(lo), float(hi)),
        "rmse_deg": (math.nan,) * 3,
        "per_trial": {int(k): (float(v), 1.0) for k, v in zip(keys, ll)},
    }


def _write_displacement(path: Path, rows: np.ndarray, gen: str, cfg: dict) -> None:
    """The displacement reports as CSV (not ``fit``'s format: a direction report per trial), with a sidecar."""
    import csv
    import io

    from ..folders import atomic_write_text, write_json

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["saccade_amplitude_deg", "blank_ms", "step_deg", "reported_forward", "seed", "paradigm"])
    for r in rows:
        w.writerow([f"{r[0]:g}", int(r[1]), f"{r[2]:g}", int(r[3]), int(r[5]), "displacement"])
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json(
        path.with_suffix(".json"),
        {
            "generated_by": "python -m experiments crossval",
            "model": gen,
            "crossval_condition": "displacement",
            "note": "a simulated observer's forward/backward reports of a target step during a 20 deg saccade "
            "in the dark, blanked blank_ms after it (the theory at its defaults, motor noise, its report noise)",
            "motor_noise": cfg["motor_noise"],
            "seed": cfg["seed"],
            "rows": len(rows),
        },
    )
    atomic_write_text(path, buf.getvalue())


# ---------------------------------------------------------------------------------------------- scoring
def _predict(theory: str, params: dict, cond: _Condition) -> np.ndarray:
    """(trials, flashes, 2) predicted positions of each flash of ``cond``'s trials (one flash, or two in
    the separation paradigm; NaN where a flash is lost)."""
    from .likelihood import FIT_MODELS

    rcfg = FIT_MODELS[theory].trial_config(cond.runner.config, params)
    prefixes = _flash_prefixes(cond.config)
    out = []
    for o in cond.observations:
        r = cond.runner.readout(o, rcfg)
        out.append([(r[f"{p}perceived_x_deg"], r[f"{p}perceived_y_deg"]) for p in prefixes])
    return np.array(out, float)


def score(rows: np.ndarray, pred: np.ndarray, noise: tuple[float, float], axes: tuple, rng) -> dict:
    """The metrics of reports ``rows`` (their trial index in column 6, their flash in column 8 where
    present) against per-trial predictions ``pred`` ((trials, 2), or (trials, flashes, 2)): {metric:
    (value, ci_low, ci_high)}, with ``n`` (reports scored) and ``lost`` (trials not predicted: a
    flash of theirs lost). Log-density per report: the sum over ``axes`` of log N(report; prediction,
    noise[axis]); RMSE over the axes. CIs: percentile bootstrap over trials (a trial's flashes together)."""
    pred = pred[:, None, :] if pred.ndim == 2 else pred
    trial = rows[:, 6].astype(int)
    flash = rows[:, 8].astype(int) if rows.shape[1] > 8 else np.zeros(len(rows), int)
    ok_trial = np.isfinite(pred[:, :, list(axes)]).all(axis=(1, 2))
    keep = ok_trial[trial]
    r, p = rows[keep], pred[trial[keep], flash[keep]]
    lost = int(np.sum(~ok_trial[np.unique(trial)]))
    if not len(r):
        return {
            "n": 0,
            "lost": lost,
            "loglik_per_report": (math.nan,) * 3,
            "rmse_deg": (math.nan,) * 3,
            "per_trial": {},
        }
    ll = np.zeros(len(r))
    sq = np.zeros(len(r))
    for a in axes:
        s = float(noise[a])
        d = r[:, 4 + a] - p[:, a]
        ll += -0.5 * (math.log(2 * math.pi * s * s) + d * d / (s * s))
        sq += d * d
    # per trial sums, resampled by trial (its reports share one prediction)
    ids, inv = np.unique(r[:, 6].astype(int), return_inverse=True)
    cnt = np.bincount(inv).astype(float)
    ll_t, sq_t = np.bincount(inv, ll), np.bincount(inv, sq)
    k = len(axes)

    def stats(w):
        n = w @ cnt
        return (w @ ll_t) / n, math.sqrt((w @ sq_t) / (n * k))

    point = stats(np.ones(len(ids)))
    draws = rng.integers(0, len(ids), size=(N_BOOT, len(ids)))
    boot = np.array([stats(np.bincount(d, minlength=len(ids)).astype(float)) for d in draws])
    lo, hi = np.percentile(boot, [2.5, 97.5], axis=0)
    return {
        "n": int(len(r)),
        "lost": lost,
        "loglik_per_report": (point[0], lo[0], hi[0]),
        "rmse_deg": (point[1], lo[1], hi[1]),
        "per_trial": {int(t): (float(a), float(c)) for t, a, c in zip(ids, ll_t, cnt)},
    }


def paired_difference(a: dict, b: dict, rng) -> tuple[float, float, float, int]:
    """Log-likelihood per report of ``a`` minus ``b`` (``score``'s ``per_trial``: trial -> (sum of
    log-densities, reports)) over the trials both predict, with a 95 % percentile bootstrap
    interval that resamples trials for both at once (a paired comparison: the theories' errors on
    a trial are correlated). Returns (difference, ci_low, ci_high, reports)."""
    common = sorted(set(a) & set(b))
    if not common:
        return math.nan, math.nan, math.nan, 0
    d = np.array([a[t][0] - b[t][0] for t in common])
    cnt = np.array([a[t][1] for t in common])
    point = float(d.sum() / cnt.sum())
    draws = rng.integers(0, len(common), size=(N_BOOT, len(common)))
    w = np.stack([np.bincount(x, minlength=len(common)) for x in draws]).astype(float)
    boot = (w @ d) / (w @ cnt)
    lo, hi = np.percentile(boot, [2.5, 97.5])
    return point, float(lo), float(hi), int(cnt.sum())


# ---------------------------------------------------------------------------------------------- driver
def _warm_up(cfg: dict, design, progress: bool) -> None:
    """Load the head and compile the kernels (the renderer's, the retina's, each theory's read-out)
    once, as a stage of its own, so the later stages' progress bars time work, not compilation."""
    from ..psychophysics import TrialConfig, TrialRunner
    from .likelihood import FIT_MODELS

    theories = sorted(set(cfg["theories"]) | set(cfg["data_from"]))
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=1 + len(theories), desc="warm-up (loading the head, compiling)", unit="step")
    runner = TrialRunner(TrialConfig(image_size=cfg["image_size"]))
    try:
        obs = runner.observe(dataclasses.replace(next(iter(design.trials())), seed=0))
        if bar is not None:
            bar.update(1)
        for name in theories:
            m = FIT_MODELS[name]
            runner.readout(obs, m.trial_config(runner.config, {p.name: p.default for p in m.parameters}))
            if bar is not None:
                bar.update(1)
    finally:
        runner.close()
        if bar is not None:
            bar.close()


def crossvalidate(
    out,
    *,
    quick: bool = False,
    seed: int = 0,
    theories=THEORIES,
    data_from=None,
    reports: int | None = None,
    noise_deg: float = 1.5,
    image_size: int | None = None,
    max_evals: int | None = None,
    backend: str = "local",
    workers: int = 1,
    ray_address: str | None = None,
    progress: bool = False,
) -> list[dict]:
    """Simulate each data set, fit each theory on each fit set, score it on the held-out conditions;
    writes ``crossval.csv``, ``crossval_pairs.csv``, ``crossval.png``, ``summary.txt`` in ``out`` and
    returns the rows of ``crossval.csv``."""
    from ..folders import write_csv
    from ..psychophysics.runner import folder_lock
    from .fitting import _fit_in
    from .forward import ForwardModel
    from .likelihood import FIT_MODELS

    cfg = settings(
        quick=quick,
        seed=seed,
        theories=theories,
        data_from=data_from,
        reports=reports,
        noise_deg=noise_deg,
        image_size=image_size,
        max_evals=max_evals,
    )
    design = _design(cfg["quick"], cfg["seed"])
    options = dict(backend=backend, workers=workers, ray_address=ray_address, progress=progress)
    rows: list[dict] = []
    with folder_lock(out) as out:
        _claim_folder(out, cfg)
        _warm_up(cfg, design, progress)
        conds, data, bar, per_trial = {}, {}, None, {}
        if progress:
            from tqdm import tqdm
        try:
            for c, name in enumerate(CONDITIONS):
                cond, noisy_obs, noisy_runner = _observe(name, design, cfg, out, options)
                conds[name] = cond
                try:
                    for g, gen in enumerate(cfg["data_from"]):
                        data[gen, name] = _simulate(gen, cond, noisy_obs, noisy_runner, cfg, g, c)
                        _write_data(out / "data" / gen / f"{name}.csv", data[gen, name], cond, design, gen, cfg)
                finally:
                    noisy_runner.close()
            displacement = _displacement_design(cfg["quick"], cfg["seed"])
            if progress:
                n_disp = len(cfg["data_from"]) * len(displacement.trials())
                bar = tqdm(total=n_disp, desc="crossval: displacement reports", unit="trial")
            for gen in cfg["data_from"]:
                data[gen, "displacement"] = _simulate_displacement(gen, displacement, cfg, bar)
                _write_displacement(out / "data" / gen / "displacement.csv", data[gen, "displacement"], gen, cfg)
            if bar is not None:
                bar.close()
                bar = None
            n_fits = len(cfg["data_from"]) * len(HELDOUT) * len(cfg["theories"])
            if progress:
                bar = tqdm(total=n_fits, desc="crossval: fits", unit="fit")
            for g, gen in enumerate(cfg["data_from"]):
                for fit_set, (cname, axes, heldout) in HELDOUT.items():
                    cond = conds[cname]
                    train = data[gen, cname]
                    ld = _localization(train, cond.config.condition, axes, str(out / "data" / gen / f"{cname}.csv"))
                    offsets = np.array(
                        [[cond.trials[int(k)].flash_dx_deg, cond.trials[int(k)].flash_dy_deg] for k in train[:, 6]]
                    )
                    fwd = ForwardModel(
                        config=cond.config,
                        offset_deg=offsets,
                        seed=np.zeros(len(train), np.int64),
                        source="crossval: the design's trials without motor noise",
                    )
                    prepared: list = []
                    for theory in cfg["theories"]:
                        sub = (
                            out
                            / "fits"
                            / gen
                            / fit_set.replace(" ", "_").replace("(", "").replace(")", "")
                            / theory.replace("/", "_")
                        )
                        sub.mkdir(parents=True, exist_ok=True)
                        with folder_lock(sub):
                            fit = _fit_in(
                                FIT_MODELS[theory], ld, fwd, sub, out, cfg["max_evals"], progress, options, prepared
                            )
                        params = fit["parameters"]
                        noise_x = params["noise_x_deg"]
                        noise = (noise_x, params["noise_y_deg"] if 1 in axes else noise_x)
                        scored = [(cname if 1 in axes else f"{cname} (x)", cname, axes, "training")]
                        scored += [(h, hc, hax, "held-out") for h, hc, hax in heldout]
                        for label, hc, hax, role in scored:
                            rng = np.random.default_rng([cfg["seed"], g, len(rows)])
                            if hc == "displacement":  # a direction report: a binary likelihood
                                s = score_binary(data[gen, hc], _predict_displacement(theory, params, cfg), rng)
                            else:
                                s = score(data[gen, hc], _predict(theory, params, conds[hc]), noise, hax, rng)
                            per_trial[f"simulated:{gen}", fit_set, label, theory] = s["per_trial"]
                            for metric in ("loglik_per_report", "rmse_deg"):
                                v, lo, hi = s[metric]
                                rows.append(
                                    {
                                        "data": f"simulated:{gen}",
                                        "theory": theory,
                                        "fit_set": fit_set,
                                        "condition": label,
                                        "role": role,
                                        "metric": metric,
                                        "value": _r(v),
                                        "ci_low": _r(lo),
                                        "ci_high": _r(hi),
                                        "n": s["n"],
                                        "lost": s["lost"],
                                    }
                                )
                        if bar is not None:
                            bar.update(1)
        finally:
            if bar is not None:
                bar.close()
            for cond in conds.values():
                cond.runner.close()
        pairs = _pairs(rows, per_trial, cfg["seed"])
        write_csv(out / "crossval.csv", COLUMNS, rows)
        write_csv(out / "crossval_pairs.csv", PAIR_COLUMNS, pairs)
        _plot(rows, cfg, out / "crossval.png")
        from ..folders import atomic_write_text

        atomic_write_text(out / "summary.txt", summary(rows, cfg, pairs))
    return rows


def _r(v: float):
    return "" if not math.isfinite(v) else round(float(v), 6)


# ---------------------------------------------------------------------------------------------- reports
def winners(rows: list[dict], metric: str = "loglik_per_report") -> list[dict]:
    """Per data set and held-out condition: the theories ranked by ``metric`` (best first)."""
    better = max if metric.startswith("loglik") else min
    out = []
    keys = dict.fromkeys((r["data"], r["fit_set"], r["condition"]) for r in rows if r["role"] == "held-out")
    for data, fit_set, cond in keys:
        mine = [
            r
            for r in rows
            if (r["data"], r["fit_set"], r["condition"], r["metric"]) == (data, fit_set, cond, metric)
            and r["value"] != ""
        ]
        if not mine:
            continue
        best = better(mine, key=lambda r: float(r["value"]))
        ranked = sorted(mine, key=lambda r: float(r["value"]), reverse=better is max)
        out.append(
            {
                "data": data,
                "fit_set": fit_set,
                "condition": cond,
                "best": best["theory"],
                "ranking": [(r["theory"], float(r["value"])) for r in ranked],
            }
        )
    return out


def markdown_table(rows: list[dict], theories: tuple[str, ...] = THEORIES) -> str:
    """The held-out log-likelihood per report as a Markdown table (one row per data set and held-out
    condition, one column per fitted theory, the best in bold): the docs' table, rendered from a
    ``crossval.csv`` (the committed one is ``experiments/data/crossval.csv``)."""
    lines = [
        "| data simulated by | fit on → held out | " + " | ".join(theories) + " |",
        "|---|---|" + "---|" * len(theories),
    ]
    for w in winners(rows):
        values = dict(w["ranking"])
        cells = [
            "" if t not in values else (f"**{values[t]:.2f}**" if t == w["best"] else f"{values[t]:.2f}")
            for t in theories
        ]
        gen = w["data"].split(":", 1)[1]
        lines.append(f"| {gen} | {w['fit_set']} → {w['condition']} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _pairs(rows: list[dict], per_trial: dict, seed: int) -> list[dict]:
    """Per data set and held-out condition: the best theory minus the runner-up (paired bootstrap)."""
    out = []
    for k, w in enumerate(winners(rows)):
        if len(w["ranking"]) < 2:
            continue
        best, second = w["ranking"][0][0], w["ranking"][1][0]
        key = (w["data"], w["fit_set"], w["condition"])
        d, lo, hi, n = paired_difference(
            per_trial[(*key, best)], per_trial[(*key, second)], np.random.default_rng([seed, 7919, k])
        )
        out.append(
            {
                "data": w["data"],
                "fit_set": w["fit_set"],
                "condition": w["condition"],
                "best": best,
                "runner_up": second,
                "delta_loglik_per_report": _r(d),
                "ci_low": _r(lo),
                "ci_high": _r(hi),
                "n": n,
                "separated": bool(math.isfinite(lo) and lo > 0),
            }
        )
    return out


def summary(rows: list[dict], cfg: dict, pairs: list[dict] | None = None) -> str:
    lines = [
        f"python -m experiments crossval: {'--quick, ' if cfg['quick'] else ''}seed {cfg['seed']}, "
        f"{cfg['image_size']} px, {cfg['reports']} reports per trial, report noise {cfg['noise_deg']:g} deg, "
        f"motor noise {cfg['motor_noise']:g}, {cfg['max_evals']} evaluations per fit",
        "data: simulated observers (each generating theory at its defaults); no published condition-level "
        "data set is in the repository",
        "",
        "held-out log-likelihood per report (higher is better), best first:",
    ]
    wins = winners(rows)
    own = 0
    for w in wins:
        gen = w["data"].split(":", 1)[1]
        own += w["best"] == gen
        text = ", ".join(f"{t} {v:.2f}" for t, v in w["ranking"])
        lines.append(f"  {w['data']:22s} fit on {w['fit_set']:15s} -> {w['condition']:15s}: {text}")
    lines += ["", f"the generating theory predicts its own held-out condition best in {own} of {len(wins)} cases"]
    if pairs:
        sep = [p for p in pairs if p["separated"]]
        lines += [
            f"the best theory's lead over the runner-up (paired bootstrap over trials) excludes 0 in "
            f"{len(sep)} of {len(pairs)} cases"
        ]
        for p in pairs:
            if not p["separated"]:
                lines.append(
                    f"  not separated: {p['data']} {p['condition']}: {p['best']} - {p['runner_up']} = "
                    f"{p['delta_loglik_per_report']} [{p['ci_low']}, {p['ci_high']}]"
                )
    lost = [r for r in rows if r["lost"] and r["metric"] == "rmse_deg"]
    for r in lost:
        lines.append(
            f"note: {r['theory']} loses {r['lost']} trial(s) of {r['condition']} ({r['data']}); scored on the others"
        )
    lines += [
        "",
        "predicted, never fitted: separation (two flashes per trial) and displacement (a direction report, "
        "scored by its Bernoulli likelihood): the fit models one position report of one flash",
    ]
    return "\n".join(lines) + "\n"


def _plot(rows: list[dict], cfg: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = list(dict.fromkeys((r["fit_set"], r["condition"]) for r in rows if r["role"] == "held-out"))
    datas = [f"simulated:{g}" for g in cfg["data_from"]]
    theories = cfg["theories"]
    fig, axs = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 4.0), squeeze=False)
    width = 0.7 / len(theories)
    for ax, (fit_set, cond) in zip(axs[0], panels):
        for j, th in enumerate(theories):
            vals, lo, hi = [], [], []
            for d in datas:
                r = next(
                    (
                        r
                        for r in rows
                        if (r["data"], r["theory"], r["fit_set"], r["condition"], r["metric"])
                        == (d, th, fit_set, cond, "loglik_per_report")
                    ),
                    None,
                )
                if r is not None and r["value"] != "":
                    v = float(r["value"])
                    vals.append(v)
                    lo.append(v - float(r["ci_low"]))
                    hi.append(float(r["ci_high"]) - v)
                else:
                    vals.append(np.nan)
                    lo.append(0.0)
                    hi.append(0.0)
            x = np.arange(len(datas)) + (j - (len(theories) - 1) / 2) * width
            ax.errorbar(x, vals, yerr=[lo, hi], fmt="o", color=f"C{j}", label=th, capsize=2, ms=5)
        for k in range(1, len(datas)):
            ax.axvline(k - 0.5, color="0.85", lw=0.8)
        ax.set_xticks(range(len(datas)), [d.split(":", 1)[1] for d in datas])
        ax.set(
            title=f"fit: {fit_set} -> {cond}", xlabel="data simulated by", ylabel="held-out log-likelihood per report"
        )
    handles, labels = axs[0][0].get_legend_handles_labels()
    fig.legend(
        handles, labels, loc="lower center", ncol=len(theories), title="fitted theory", fontsize=8, title_fontsize=8
    )
    fig.suptitle("cross-validation: which theory generalises (higher is better; 95 % bootstrap CI)")
    fig.tight_layout(rect=(0, 0.12, 1, 1))
    save_figure(fig, path, dpi=100)
