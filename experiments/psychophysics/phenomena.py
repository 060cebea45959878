"""``python -m experiments phenomena``: which published perisaccadic phenomena each theory predicts.

Every perception model (``psychophysics.MODELS``: the rival theories ``observer`` and
``population``, the seed's ``paper`` model and the ``mechanistic`` composite) and a ``baseline``
(all mechanisms off: the true eye, no remapping, no references -- what the retina alone gives)
reads out the *same* observed trials: each design is rendered and seen by the retina once
(``modelfit.observe_trials``, cached in ``DIR/observations/``, so an interrupted run resumes), at
256 px, by a simulated participant (``psychophysics.participant``) whose saccades land with motor
noise and whose reports scatter, at published levels. Every design cell (flash time x position)
holds ``REPETITIONS`` trials with their own seeds.

Each row of ``phenomena.csv`` (``psychophysics.scoring.SCORE_COLUMNS``) is one statistic, its
95 % CI (``--bootstrap`` resamples of the trials within each cell: the experiment repeated), the
published range it is compared with and the paper's figure it is read from, and three verdicts set
by rules (``psychophysics.scoring``), never by hand: ``role`` (``predicted`` only if no constant of
the model came from the row's source, by ``experiments/data/calibration.csv``), ``reproduced``
(``yes`` only if the whole CI lies in the range) and ``diagnostic`` (``no`` where the baseline also
reproduces the row). See ``ROWS`` for every statistic's definition, range and source.

Designs (20 deg saccades unless said; 24 flash positions around the target, as Fig. 11; 4
repetitions): references and dark (11 flash times, -150..150 ms); amplitude (12 and 24 deg, -25
and 0 ms); reference contrast 0.25; references only before saccade offset (``reference_ms`` 0); two simultaneous flashes 4 deg apart (separation); without the
ruler: the target extinguished at onset with a marker 10 deg before it (focus), the target lit
(target only) and the target extinguished 100 ms before onset (memory-guided); a target step during
the saccade with and without a 250 ms blank (displacement: 13 steps of 0.5 deg from -3 to +3, 30
repetitions each): 3,744 localization trials and 3,900 displacement trials. 4 min 8 s from nothing
with ``--workers 2`` on 2 cores (the last run, beside light other work; it gave the committed table byte
for byte); a run with the observations already cached, 1 min 42 s; a re-run reads the cached
observations and displacement tables and takes the read-outs' and bootstrap's time.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..cli.progress import stage
from .scoring import SCORE_COLUMNS

__all__ = [
    "write_results",
    "ROWS",
    "THEORIES",
    "COLUMNS",
    "REPETITIONS",
    "measure",
    "score",
    "bootstrap",
    "statistics",
    "resample_cells",
    "markdown_table",
]

IMAGE_SIZE = 256
TIMES = (-150, -100, -75, -50, -25, 0, 25, 50, 75, 100, 150)
NEAR = (-25, 0)  # "near onset": the flash times where published compression is strongest
#: Perception models scored, and the baseline (all mechanisms off).
THEORIES = ("observer", "population", "paper", "mechanistic", "baseline")
MARKER = (-10.0, 0.0)  # the focus design's marker, deg from the target
BOOT = 1000
#: Trials per design cell (flash time x position; ``--quick``: 2), each with its own seed.
REPETITIONS = 4
#: Displacement steps (deg along the saccade) and reports per step and blank (``--quick``: 1 deg, 6).
STEPS_DEG = tuple(float(s) for s in np.arange(-3.0, 3.01, 0.5))
STEP_REPETITIONS = 30

#: phenomenon -> (published statement, source (citation, figure), published range (lo, hi) or None, unit)
ROWS = {
    "compression_peak": (
        "peak compression ~50 % for 20 deg saccades with references",
        "Morrone, Ross & Burr 1997, Fig. 3",
        (0.35, 0.65),
        "index",
    ),
    "compression_peak_time_ms": (
        "compression is maximal just before saccade onset",
        "Morrone, Ross & Burr 1997, abstract",
        (-50.0, 0.0),
        "ms",
    ),
    "compression_onset_ms": (
        "errors appear up to 100 ms before the saccade: first time at half the peak",
        "Morrone, Ross & Burr 1997, abstract",
        (-100.0, -25.0),
        "ms",
    ),
    "compression_fwhm_ms": (
        "compression confined to roughly +-50 ms around onset: full width at half maximum",
        "Morrone, Ross & Burr 1997, Fig. 3",
        (40.0, 110.0),
        "ms",
    ),
    "compression_fixation": (
        "no compression during fixation, long before the saccade (errors appear up to 100 ms "
        "before it): index at -150 ms with references; the range is the index's tolerance "
        "around none",
        "Morrone, Ross & Burr 1997, abstract",
        (-0.1, 0.1),
        "index",
    ),
    "shift_with_references_deg": (
        "no published number for the uniform shift with references: the model's mean "
        "horizontal error at 0 ms minus -150 ms, with references",
        "none found",
        None,
        "deg",
    ),
    "compression_amplitude_growth": (
        "compression grows with saccade amplitude: index 24 deg minus 12 deg near onset",
        "Lavergne, Vergilino-Perez, Lappe & Dore-Mazars 2010, abstract",
        (0.02, 1.0),
        "index",
    ),
    "shift_dark_presaccadic_deg": (
        "in the dark, flashes before onset are seen shifted in the saccade's direction: "
        "mean error at -50 minus -150 ms",
        "Honda 1989, abstract; Honda 1991",
        (0.5, 10.0),
        "deg",
    ),
    "shift_dark_reversal_deg": (
        "flashes near the end of the saccade are seen shifted against it: mean error at +50 minus -150 ms",
        "Honda 1989, abstract; Honda 1991",
        (-10.0, -0.5),
        "deg",
    ),
    "compression_needs_references": (
        "compression with post-saccadic references, none in complete darkness: index references minus dark near onset",
        "Lappe, Awater & Krekelberg 2000, Fig. 2",
        (0.2, 1.0),
        "index",
    ),
    "compression_needs_postsaccadic_references": (
        "compression needs references present after the saccade, not only "
        "before it: index with the target and ruler on after saccade "
        "offset minus with the target on only until offset (reference_ms "
        "0), near onset; the paper's figure was not checked, so no range",
        "Lappe, Awater & Krekelberg 2000 (figure not checked)",
        None,
        "index",
    ),
    "compression_vs_reference_contrast": (
        "no published grading with the references' contrast found: the model's "
        "prediction (index at contrast 1 minus 0.25, near onset)",
        "none found",
        None,
        "index",
    ),
    "compression_along_minus_across": (
        "2-D compression, stronger along the saccade than across it: index along minus across near onset",
        "Kaiser & Lappe 2004, Fig. 3",
        (0.05, 1.0),
        "index",
    ),
    "compression_across": (
        "compression also across the saccade: index across near onset",
        "Kaiser & Lappe 2004, Fig. 3",
        (0.05, 1.0),
        "index",
    ),
    "separation_over_localization": (
        "perceived separation of two simultaneous flashes compresses much less than "
        "their localization: ratio near onset",
        "Reeve, Clark & O'Regan 2008, abstract",
        (-1.0, 0.5),
        "ratio",
    ),
    "displacement_blank_ratio": (
        "a 50-300 ms post-saccadic blank restores detection of intrasaccadic target steps: "
        "threshold without / with a 250 ms blank",
        "Deubel, Schneider & Bridgeman 1996, Fig. 2",
        (2.0, 1000.0),
        "ratio",
    ),
    "focus_toward_reference": (
        "with no target after onset, compression is focused on a visible reference object: "
        "focus position from the goal (0) to the marker (1)",
        "Zimmermann, Morrone & Burr 2014, abstract",
        (0.5, 1.5),
        "fraction",
    ),
    "memory_guided_reduction": (
        "memory-guided saccades (no visible target) give weaker, more veridical "
        "localization: index with the target lit minus with it off from 100 ms before "
        "onset, no ruler, near onset",
        "Zimmermann, Morrone & Burr 2014, abstract",
        (0.05, 1.0),
        "index",
    ),
}


def _designs(quick: bool = False) -> dict:
    """name -> (Design, TrialConfig overrides): everything the rows need (``quick``: 8 flash
    positions instead of 24, 2 repetitions instead of ``REPETITIONS``)."""
    from . import FIG11_OFFSETS_DEG, MORRONE_OFFSETS_DEG, Design

    pos = MORRONE_OFFSETS_DEG if quick else FIG11_OFFSETS_DEG
    reps = 2 if quick else REPETITIONS

    def design(name, times, amplitudes=(20.0,)):
        return Design(
            amplitudes_deg=amplitudes, flash_offsets_deg=pos, flash_times_ms=times, repetitions=reps, name=name
        )

    loc, near = design("localization", TIMES), design("near", NEAR)
    return {
        "references": (loc, dict(condition="references")),
        "dark": (loc, dict(condition="dark")),
        "amplitude": (design("amplitude", NEAR, (12.0, 24.0)), dict(condition="references")),
        "contrast_0.25": (near, dict(condition="references", reference_contrast=0.25)),
        "references_before": (near, dict(condition="references", reference_ms=0)),
        "separation": (design("separation", (-150,) + NEAR), dict(condition="references", paradigm="separation")),
        "focus": (near, dict(condition="references", target_off_ms=0, markers=(MARKER,), ruler=False)),
        "target_only": (near, dict(condition="references", ruler=False)),
        "memory": (near, dict(condition="references", target_off_ms=-100, ruler=False)),
    }


def _displacement(quick: bool = False):
    from . import Design

    steps = tuple(float(s) for s in range(-3, 4)) if quick else STEPS_DEG
    return Design(
        amplitudes_deg=(20.0,),
        flash_offsets_deg=tuple((s, 0.0) for s in steps),
        flash_times_ms=(0, 250),
        repetitions=6 if quick else STEP_REPETITIONS,
        name="displacement",
    )


def _model_config(base, model: str):
    """``base`` read out by ``model`` (``baseline``: the true eye, no remapping, no references)."""
    import dataclasses

    from . import RemapTimeCourse

    if model == "baseline":
        return dataclasses.replace(base, model="paper", timecourse=RemapTimeCourse(peak_gain=0.0), eye_position="true")
    return dataclasses.replace(base, model=model)


def _columns(rows: list[dict]) -> dict[str, np.ndarray]:
    return {k: np.array([r[k] for r in rows]) for k in rows[0]}


def measure(
    out: Path,
    models=THEORIES,
    workers: int = 1,
    progress: bool = False,
    image_size: int = IMAGE_SIZE,
    quick: bool = False,
    generator=None,
    backend: str = "local",
    ray_address: str | None = None,
) -> dict:
    """Observe every design once (cached), read it out with every model; returns {model: {design:
    table}}, the localization tables holding the participant's reports (``participant.add_report_noise``;
    ``DIR/tables/`` keeps the models' percepts). Saccades land with the participant's motor noise.
    ``generator``: the burst generator's parameters (``models.BurstGenerator``; None: its defaults).
    ``workers``, ``backend``, ``ray_address``: where the trials run (``backends``)."""
    from ..folders import write_csv
    from ..modelfit.observe import observe_trials
    from . import ROW_COLUMNS, TEXT_COLUMNS, TrialConfig, TrialRunner, read_table, run_trials
    from .participant import PARTICIPANT, add_report_noise

    noise = PARTICIPANT.endpoint_noise
    tables: dict = {m: {} for m in models}
    (out / "tables").mkdir(parents=True, exist_ok=True)
    designs = _designs(quick)
    for k, (name, (design, kw)) in enumerate(designs.items(), 1):
        base = TrialConfig(image_size=image_size, generator=generator, endpoint_noise=noise, **kw)
        stage(
            f"phenomena: design {k}/{len(designs)} ({name}, {design.n_trials} trials): loading the head",
            enabled=progress,
        )
        runner = TrialRunner(base)
        try:
            obs = observe_trials(
                design.trials(),
                base,
                out / "observations",
                workers=workers,
                progress=progress,
                runner=runner,
                backend=backend,
                ray_address=ray_address,
            )
            stage(
                f"phenomena: design {k}/{len(designs)} ({name}): reading out {len(models)} theories", enabled=progress
            )
            for m in models:
                rows = [{**runner.readout(o, _model_config(base, m)), "model": m} for o in obs]
                write_csv(out / "tables" / f"{m}_{name}.csv", list(ROW_COLUMNS + TEXT_COLUMNS), rows)
                tables[m][name] = add_report_noise(_columns(rows), PARTICIPANT, name)
        finally:
            runner.close()
    for m in models:
        stage(f"phenomena: saccadic suppression of displacement, {m}", enabled=progress)
        cfg = _model_config(
            TrialConfig(
                image_size=image_size,
                condition="dark",
                paradigm="displacement",
                generator=generator,
                endpoint_noise=noise,
            ),
            m,
        )
        path = run_trials(
            _displacement(quick),
            cfg,
            out / "displacement" / m,
            workers=workers,
            progress=progress,
            backend=backend,
            ray_address=ray_address,
        )
        tables[m]["displacement"] = read_table(path)
    return tables


# ---------------------------------------------------------------------------------------- statistics
def _index(t: dict, sel: np.ndarray, axis: int | None = None) -> float:
    """Compression index of the selected flashes: 1 - perceived / true spread (RMS about the mean)
    of the mean report per flash position (over its repetitions; flashes the retina missed, with no
    report, left out), the perceived spread corrected for the report noise left in those means (the
    mean within-position variance / repetitions subtracted: else noise alone would lower the index), in 2-D, or along one axis (0 =
    along the saccade, 1 = across). NaN where the perceived spread is not above that noise (flashes
    collapsed within the reports' scatter: the index is not defined)."""
    cols = (("perceived_x_deg", "true_x_deg"), ("perceived_y_deg", "true_y_deg"))
    use = cols if axis is None else (cols[axis],)
    sel = sel & np.isfinite(t["perceived_x_deg"]) & np.isfinite(t["perceived_y_deg"])  # a flash not seen: no report
    if not sel.any():
        return float("nan")
    key = t["flash_dx_deg"][sel] + 1j * t["flash_dy_deg"][sel] + 1e3 * t["saccade_amplitude_deg"][sel]
    _, cell = np.unique(key, return_inverse=True)
    n = np.bincount(cell)
    dof = np.maximum(n - 1, 1)

    def spread(col: str) -> float:  # (sum / size: np.mean's own arithmetic, without its per-call checks)
        v = t[col][sel]
        m = np.bincount(cell, v) / n
        within = np.bincount(cell, (v - m[cell]) ** 2) / dof  # each cell's report variance
        between = (m - m.sum() / m.size) ** 2
        noise = within / n
        return float(between.sum() / between.size - noise.sum() / noise.size)

    num = sum(spread(p) for p, _ in use)
    den = sum(spread(q) for _, q in use)
    if not num >= 0:  # the perceived spread is not above the report noise left in the means: no index
        return float("nan")
    return float(1 - np.sqrt(num / den))


def _curve(t: dict) -> tuple[np.ndarray, np.ndarray]:
    times = np.unique(t["flash_time_ms"])
    return times, np.array([_index(t, t["flash_time_ms"] == s) for s in times])


def _near(t: dict, axis: int | None = None, amplitude: float | None = None) -> float:
    sel = np.isin(t["flash_time_ms"], NEAR)
    if amplitude is not None:
        sel &= t["saccade_amplitude_deg"] == amplitude
    # per flash time, then averaged: the index is defined over one time's flashes
    return float(
        np.mean(
            [_index(t, sel & (t["flash_time_ms"] == s), axis) for s in NEAR if (sel & (t["flash_time_ms"] == s)).any()]
        )
    )


def _half_crossings(times, vals) -> tuple[float, float, float]:
    """(peak time, first time at half the peak (interpolated), full width at half maximum)."""
    i = int(np.argmax(vals))
    half = vals[i] / 2
    if not vals[i] > 0:
        return float(times[i]), float("nan"), float("nan")

    def cross(order):
        prev = i
        for j in order:
            if vals[j] < half:
                return times[prev] + (vals[prev] - half) / (vals[prev] - vals[j]) * (times[j] - times[prev])
            prev = j
        return float("nan")

    left, right = cross(range(i - 1, -1, -1)), cross(range(i + 1, len(times)))
    return float(times[i]), float(left), float(right - left)


def _mean_error_x(t: dict, time: int) -> float:
    return float(t["error_x_deg"][t["flash_time_ms"] == time].mean())


def _separation_ratio(t: dict) -> float:
    sel = np.isin(t["flash_time_ms"], NEAR)
    true = np.hypot(t["second_true_x_deg"] - t["true_x_deg"], t["second_true_y_deg"] - t["true_y_deg"])[sel]
    seen = np.hypot(
        t["second_perceived_x_deg"] - t["perceived_x_deg"], t["second_perceived_y_deg"] - t["perceived_y_deg"]
    )[sel]
    sep = 1 - seen.mean() / true.mean()
    return float(sep / _near(t))


def _focus(t: dict) -> float:
    """Where the perceived positions converge along x: the fixed point of the least-squares line
    perceived = a + b true, relative to the goal (0) and the marker (1)."""
    sel = np.isin(t["flash_time_ms"], NEAR)
    x, y = t["true_x_deg"][sel], t["perceived_x_deg"][sel]
    b, a = np.polyfit(x, y, 1)
    goal = float(np.mean(t["target_x_deg"]))
    return float((a / (1 - b) - goal) / MARKER[0]) if b < 1 else float("nan")


def _threshold_ratio(t: dict, start: dict | None = None) -> float:
    from . import displacement_psychometrics

    fits = displacement_psychometrics(t, start=start)
    return float(fits[0]["threshold_deg"] / fits[250]["threshold_deg"])


def statistics(tab: dict, psychometric_start: dict | None = None, rows=None) -> dict[str, float]:
    """Every ``ROWS`` statistic of one model's tables (``psychometric_start``: as for
    ``displacement_psychometrics``); ``rows``: only these (``ROWS`` names), each reading only the
    designs it needs (``timing_sweep`` reads three)."""
    ref: dict = tab.get("references", {})  # (a row that needs a design the tables lack: KeyError)
    dark: dict = tab.get("dark", {})
    course: list = []  # the references' time course, computed once when a row asks for it

    def timing(k: int) -> float:
        if not course:
            times, curve = _curve(ref)
            course.extend((float(curve.max()), *_half_crossings(times, curve)))
        return course[k]

    rules = {
        "compression_peak": lambda: timing(0),
        "compression_peak_time_ms": lambda: timing(1),
        "compression_onset_ms": lambda: timing(2),
        "compression_fwhm_ms": lambda: timing(3),
        "compression_fixation": lambda: _index(ref, ref["flash_time_ms"] == TIMES[0]),
        "shift_with_references_deg": lambda: _mean_error_x(ref, 0) - _mean_error_x(ref, TIMES[0]),
        "compression_amplitude_growth": lambda: (
            _near(tab["amplitude"], amplitude=24.0) - _near(tab["amplitude"], amplitude=12.0)
        ),
        "shift_dark_presaccadic_deg": lambda: _mean_error_x(dark, -50) - _mean_error_x(dark, -150),
        "shift_dark_reversal_deg": lambda: _mean_error_x(dark, 50) - _mean_error_x(dark, -150),
        "compression_needs_references": lambda: _near(ref) - _near(dark),
        "compression_needs_postsaccadic_references": lambda: _near(ref) - _near(tab["references_before"]),
        "compression_vs_reference_contrast": lambda: _near(ref) - _near(tab["contrast_0.25"]),
        "compression_along_minus_across": lambda: _near(ref, 0) - _near(ref, 1),
        "compression_across": lambda: _near(ref, 1),
        "separation_over_localization": lambda: _separation_ratio(tab["separation"]),
        "displacement_blank_ratio": lambda: _threshold_ratio(tab["displacement"], psychometric_start),
        "focus_toward_reference": lambda: _focus(tab["focus"]),
        "memory_guided_reduction": lambda: _near(tab["target_only"]) - _near(tab["memory"]),
    }
    return {k: rules[k]() for k in (rules if rows is None else rows)}


#: Reported columns of a localization table, resampled by ``resample_cells`` (the rest describe the stimulus).
_REPORTED = (
    ("perceived_x_deg", "true_x_deg", "error_x_deg"),
    ("perceived_y_deg", "true_y_deg", "error_y_deg"),
    ("second_perceived_x_deg", None, None),
    ("second_perceived_y_deg", None, None),
)


def _cells(t: dict) -> np.ndarray:
    """Each row's design cell (amplitude, flash time, position): the repetitions of one stimulus."""
    key = np.column_stack([t["saccade_amplitude_deg"], t["flash_time_ms"], t["flash_dx_deg"], t["flash_dy_deg"]])
    return np.unique(key, axis=0, return_inverse=True)[1].ravel()


def resample_cells(t: dict, cells: np.ndarray, rng: np.random.Generator) -> dict:
    """One bootstrap replicate of a localization table: within each design cell, the reports are
    drawn with replacement from the cell's repetitions, as deviations from the cell's mean scaled by
    sqrt(n / (n - 1)) (the cell's unbiased variance: a plain resample of n repetitions has (n - 1) / n
    of it; Davison & Hinkley 1997, eq. 3.12's modified residuals), and the errors recomputed."""
    order = np.argsort(cells, kind="stable")
    sc = cells[order]
    n = np.bincount(sc)
    first = np.concatenate([[0], np.cumsum(n)[:-1]])
    pick = order[first[sc] + (rng.random(sc.size) * n[sc]).astype(int)]
    out = dict(t)
    for col, true, err in _REPORTED:
        if col not in t:
            continue
        v = t[col]
        seen = np.isfinite(v)  # a lost flash (no report) stays lost; the cell's mean and scale are the reports'
        k = np.bincount(cells, seen, minlength=n.size)
        mean = np.bincount(cells, np.where(seen, v, 0.0), minlength=n.size) / np.maximum(k, 1)
        scale = np.where(k > 1, np.sqrt(k / np.maximum(k - 1, 1)), 1.0)
        new = np.empty_like(v)
        new[order] = mean[sc] + scale[sc] * (v[pick] - mean[sc])
        out[col] = new
        if err is not None:
            out[err] = new - t[true]
    return out


def bootstrap(tab: dict, n: int = BOOT, seed: int = 0, rows=None) -> dict[str, tuple[float, float]]:
    """95 % percentile CIs of ``statistics`` (``rows``: only these): the experiment repeated -- each
    localization design's reports resampled within its cells (``resample_cells``), the displacement
    reports (when ``tab`` has them) within each step and blank."""
    from . import displacement_psychometrics

    rng = np.random.default_rng(seed)
    disp = tab.get("displacement")
    start = None
    groups: dict = {}
    if disp is not None:
        start = {b: (r["pse_deg"], r["threshold_deg"]) for b, r in displacement_psychometrics(disp).items()}
        for i, c in enumerate(zip(disp["flash_dx_deg"], disp["flash_time_ms"])):
            groups.setdefault(c, []).append(i)
    cells = {name: _cells(t) for name, t in tab.items() if name != "displacement"}
    samples: dict[str, list] = {k: [] for k in (ROWS if rows is None else rows)}
    for _ in range(n):
        sub = {name: resample_cells(t, cells[name], rng) for name, t in tab.items() if name != "displacement"}
        if disp is not None:
            idx = np.concatenate([rng.choice(v, size=len(v), replace=True) for v in groups.values()])
            sub["displacement"] = {k: v[idx] for k, v in disp.items()}
        with np.errstate(all="ignore"):
            for k, v in statistics(sub, start, tuple(samples)).items():
                samples[k].append(v)
    out = {}
    for k, values in samples.items():
        reps = np.asarray(values, float)
        if not np.all(np.isfinite(reps)):  # an undefined replicate: the CI is undefined, not narrower
            out[k] = (float("nan"), float("nan"))
        else:
            out[k] = (float(np.percentile(reps, 2.5)), float(np.percentile(reps, 97.5)))
    return out


def _note(name: str, model: str, tab: dict, value: float, ci: tuple) -> str:
    """What a reader of the row must know: an undefined value or CI, a non-monotone psychometric fit."""
    from . import displacement_psychometrics

    notes = []
    if not np.isfinite(value):
        notes.append("undefined on these data (e.g. no half-maximum crossing, no fixed point)")
    elif not all(np.isfinite(ci)):
        notes.append("undefined in some bootstrap replicates: no CI")
    if name == "displacement_blank_ratio":
        fits = displacement_psychometrics(tab["displacement"])
        steps = np.unique(tab["displacement"]["flash_dx_deg"])
        spacing, span = float(np.min(np.diff(steps))), float(steps[-1] - steps[0])
        for b, r in fits.items():
            if not np.isfinite(r["p_forward"]).any():  # no report at this blank (analysis._no_reports)
                notes.append(f"blank {b} ms: the target lost in all {r['lost']} trials (no reports): no fit")
            elif r["threshold_deg"] < spacing:
                notes.append(
                    f"threshold {r['threshold_deg']:.2f} deg at blank {b} ms is under the {spacing:g} deg "
                    f"step: not resolved by the grid"
                )
            elif r["threshold_deg"] > span / 2 or not steps[0] < r["pse_deg"] < steps[-1]:
                notes.append(
                    f"blank {b} ms: PSE {r['pse_deg']:.2f}, threshold {r['threshold_deg']:.2f} deg reach "
                    f"beyond the steps ({steps[0]:g} to {steps[-1]:g} deg): extrapolated"
                )
        bad = [f"{b} ms" for b, r in fits.items() if not r["monotonic"] and np.isfinite(r["p_forward"]).any()]
        if bad:
            notes.append(
                "psychometric data not monotone at blank "
                + ", ".join(bad)
                + " (p = "
                + ", ".join(f"{fits[int(b.split()[0])]['monotone_p']:.2f}" for b in bad)
                + ")"
            )
    if ROWS[name][2] is None:
        notes.append("no published number: reported, not tested")
    return "; ".join(notes)


def _fmt(v: float) -> float | str:
    return round(float(v), 3) if np.isfinite(v) else "nan"


def score(tables: dict, n_boot: int = BOOT, progress: bool = False) -> list[dict]:
    """One row per (phenomenon, model) with ``scoring.SCORE_COLUMNS``, the verdicts set by
    ``scoring.finalize`` from ``experiments/data/calibration.csv``; ``progress``: a bar per model on
    stderr."""
    from ..cli.progress import Progress
    from .scoring import finalize

    rows = []
    bar = Progress(
        len(tables), desc=f"bootstrap CIs ({n_boot} resamples)", unit="theory", warmup=None, enabled=progress
    )
    for model, tab in tables.items():
        point = statistics(tab)
        ci = bootstrap(tab, n_boot)
        for name, (_statement, source, rng, _unit) in ROWS.items():
            rows.append(
                {
                    "phenomenon": name,
                    "model": model,
                    "source": source,
                    "published_low": "" if rng is None else rng[0],
                    "published_high": "" if rng is None else rng[1],
                    "simulated": _fmt(point[name]),
                    "ci_low": _fmt(ci[name][0]),
                    "ci_high": _fmt(ci[name][1]),
                    "note": _note(name, model, tab, point[name], ci[name]),
                }
            )
        bar.update()
    bar.close()
    return finalize(rows)


#: The columns of ``phenomena.csv``.
COLUMNS = list(SCORE_COLUMNS)


def markdown_table(rows: list[dict]) -> str:
    """The scoreboard as a Markdown table (docs/psychophysics/theories.md): one line per phenomenon, one column per
    model; each cell the simulated value, its 95 % CI and the verdict: **yes** / no (predicted,
    diagnostic, and the CI inside the published range or not: the rows that count), cal. yes / cal.
    no (calibrated: a constant of the model came from the row's source), n.d. (the baseline also
    reproduces the row: not diagnostic), n/t (no published number)."""
    models = list(dict.fromkeys(r["model"] for r in rows))
    cell = {(r["phenomenon"], r["model"]): r for r in rows}

    def fmt(v, unit: str) -> str:
        v = float(v)
        if not np.isfinite(v):
            return "nan"
        return f"{v:.0f}" if unit == "ms" or abs(v) >= 100 else f"{v:.2f}"

    def verdict(c: dict) -> str:
        if c["reproduced"] == "not tested":
            return "n/t"
        if c["role"] == "calibrated":
            return f"cal. {c['reproduced']}"
        if c["diagnostic"] == "no":
            return f"n.d. {c['reproduced']}"
        return "**yes**" if c["reproduced"] == "yes" else "no"

    lines = ["| phenomenon | published (source) | " + " | ".join(models) + " |", "|---|---|" + "---|" * len(models)]
    for name in dict.fromkeys(r["phenomenon"] for r in rows):
        first = cell[(name, models[0])]
        unit = ROWS[name][3] if name in ROWS else ""
        pub = (
            f"{float(first['published_low']):g} to {float(first['published_high']):g} {unit}"
            if str(first["published_low"]).strip()
            else "none found"
        )
        src = "" if first["source"].startswith("none") else f" ({first['source']})"
        cells = [
            f"{fmt(c['simulated'], unit)} [{fmt(c['ci_low'], unit)}, {fmt(c['ci_high'], unit)}] {verdict(c)}"
            for c in (cell[(name, m)] for m in models)
        ]
        lines.append(f"| `{name}` | {pub}{src} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def plot(tables: dict, out: Path) -> list[Path]:
    """Figures, each model's from its own results: compression time courses (references, dark),
    the dark shift, and the displacement psychometric functions."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from . import displacement_psychometrics

    paths = []
    models = list(tables)
    fig, axes = plt.subplots(1, len(models), figsize=(3.2 * len(models), 3.2), sharey=True)
    for ax, m in zip(np.atleast_1d(axes), models):
        for cond, style in (("references", "-o"), ("dark", "--s")):
            t, c = _curve(tables[m][cond])
            ax.plot(t, c, style, ms=3, label=cond)
        ax.axhline(0, color="0.7", lw=0.8)
        ax.axvspan(-50, 50, color="0.92", zorder=0)
        ax.set(title=m, xlabel="flash re onset (ms)")
    np.atleast_1d(axes)[0].set_ylabel("compression index (20° saccade)")
    np.atleast_1d(axes)[0].legend(fontsize=8)
    fig.suptitle("each model's own compression time course (grey: ±50 ms, Morrone et al. 1997)", fontsize=9)
    paths.append(_save(fig, out / "compression_vs_time.png"))
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    for m in models:
        d = tables[m]["dark"]
        ts = np.unique(d["flash_time_ms"])
        ax.plot(ts, [_mean_error_x(d, s) for s in ts], "-o", ms=3, label=m)
    ax.axhline(0, color="0.7", lw=0.8)
    ax.set(title="dark: mean horizontal error (saccade goes +x)", xlabel="flash re onset (ms)", ylabel="deg")
    ax.legend(fontsize=8)
    paths.append(_save(fig, out / "shift_in_dark.png"))
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    for m in models:
        for b, r in displacement_psychometrics(tables[m]["displacement"]).items():
            ax.plot(
                r["steps_deg"],
                r["p_forward"],
                "-o" if b == 0 else "--s",
                ms=3,
                label=f"{m}, blank {b} ms: {r['threshold_deg']:.2f}°",
            )
    ax.set(title="target step during the saccade", xlabel="step (deg, + forward)", ylabel='P("forward")')
    ax.legend(fontsize=6)
    paths.append(_save(fig, out / "displacement_suppression.png"))
    return paths


def _save(fig, path: Path) -> Path:
    from ..folders import save_figure

    fig.tight_layout()
    return save_figure(fig, path, dpi=100)


def write_results(out: Path, tables: dict, n_boot: int = BOOT, progress: bool = False) -> tuple[str, list]:
    """Score ``tables`` and write ``phenomena.csv``, ``.txt``, ``.md`` and the figures into ``out``;
    return the text table and the figures' paths."""
    from ..folders import atomic_write_text, write_csv
    from .scoring import counts

    rows = score(tables, n_boot, progress)
    write_csv(out / "phenomena.csv", COLUMNS, rows)
    lines = [
        f"{'phenomenon':34s} {'model':12s} {'role':10s} {'diag':4s} {'simulated':>9s}  {'95% CI':19s} "
        f"{'published':14s} reproduced"
    ]
    for r in rows:
        pub = f"{r['published_low']}..{r['published_high']}" if str(r["published_low"]).strip() else "none"
        lines.append(
            f"{r['phenomenon']:34s} {r['model']:12s} {r['role']:10s} {r['diagnostic']:4s} "
            f"{float(r['simulated']):9.3f}  [{float(r['ci_low']):7.3f}, {float(r['ci_high']):7.3f}] "
            f"{pub:14s} {r['reproduced']}" + (f"  ({r['note']})" if r["note"] else "")
        )
    tally = [f"{m}: {a}/{b} predicted, diagnostic rows reproduced" for m, (a, b) in counts(rows).items()]
    text = "\n".join(lines + [""] + tally) + "\n"
    atomic_write_text(out / "phenomena.txt", text)
    atomic_write_text(out / "phenomena.md", markdown_table(rows))
    return text, plot(tables, out)
