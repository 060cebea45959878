"""``python -m experiments saccades``: the oculomotor plant's kinematics against published data.

Runs horizontal saccades of 2-50 deg through the head's physics (``models.Head``, no rendering),
measures each eye's peak velocity, duration and skewness on the recorded traces (30 deg/s
threshold crossings) and writes:

* ``main_sequence.csv``: model, amplitude, eye (left = adducting, right = abducting for these
  rightward saccades, and the version mean), peak velocity, duration, skewness;
* ``saccades.png``: velocity profiles of 5-40 deg saccades; the main sequence (peak velocity and
  duration vs amplitude) with the published curves -- Van Wetter & Van Opstal (2008) peak
  velocity, Collewijn, Erkelens & Steinman (1988) saturation 502 +- 32 deg/s, Carpenter (1988)
  duration 2.2 A + 21 ms; and the eye-position signal against the true eye around a 20 deg
  saccade, in flash time (the signal a flash at t is read with, at t + the visual latency).

Both trajectory models (``burst``, the default, and ``legacy``) are measured, so the figure shows
what the burst generator changed. About 5 s on one core.

With ``--recording FILE`` it measures a person instead (``experiments.oculomotor.eyetracking``): it reads an
EyeLink ASC file or a CSV/TSV of samples, finds the saccades (the file's own events of the chosen
eye or Engbert & Kliegl detection; none across missing data, none near blinks), refuses
implausible ones, and writes ``recording.json`` (which file, which eye and why), ``main_sequence.csv``
(one row per saccade: amplitude, duration, peak velocity, direction, skewness),
``main_sequence.png`` and ``generator.json`` (the burst generator fitted to that main sequence,
with 95 % CIs and ``at_bounds``; usable as ``--generator`` of ``run``, ``phenomena`` and ``fit`` and
as ``models.BurstGenerator.from_file``). A fit that the saccades do not identify (too few, an
estimate on a bound, a CI wider than the parameter's range) writes no ``generator.json`` and exits
3 with one line. A folder holding another recording's results has them all removed first.
Pixels need the screen: ``--screen WIDTH_CM HEIGHT_CM DISTANCE_CM`` for ASC (resolution from the
file) or ``--screen WIDTH_PX HEIGHT_PX WIDTH_CM HEIGHT_CM DISTANCE_CM``.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from ..cli import Progress, stage
from ..folders import path_lock, save_figure, write_csv

__all__ = ["measure", "main_sequence_rows", "plot", "run_models", "run_recording"]

AMPLITUDES_DEG = (2, 5, 10, 15, 20, 25, 30, 40, 50)
PROFILE_AMPLITUDES_DEG = (5, 10, 20, 40)
THRESHOLD_DEG_S = 30.0


def _kinematics(t: np.ndarray, speed: np.ndarray) -> tuple[float, float, float]:
    above = np.flatnonzero(speed > THRESHOLD_DEG_S)
    t0, t1 = t[above[0]], t[above[-1]]
    return float(speed.max()), float(t1 - t0), float((t[np.argmax(speed)] - t0) / (t1 - t0))


def measure(model: str, amplitudes=AMPLITUDES_DEG, progress: bool = False) -> dict:
    """Run rightward horizontal saccades centred on straight ahead; returns traces and kinematics."""
    import models

    out = {}
    bar = Progress(len(amplitudes), unit="saccade", desc=f"{model} saccades", enabled=progress)
    with models.Head("dots", image_size=16, seed=0, saccade_model=model) as head, bar:
        for a in amplitudes:
            head.reset(fixate=models.screen_point(math.radians(-a / 2), 0.0, 1.0))
            plan = head.plan_saccade_to(models.screen_point(math.radians(a / 2), 0.0, 1.0), latency_ms=150)
            head.start_saccade(plan)
            tr = head.step_ms(plan.end_ms - head.time_ms + 250, record=True)
            w = np.degrees(tr.velocities[:, :, 0])
            rows = {
                "left": _kinematics(tr.times_ms, np.abs(w[:, 0])),
                "right": _kinematics(tr.times_ms, np.abs(w[:, 1])),
                "version": _kinematics(tr.times_ms, np.abs(w.mean(axis=1))),
            }
            out[a] = {"plan": plan, "trace": tr, "kinematics": rows}
            bar.update()
    return out


def main_sequence_rows(results: dict[str, dict]) -> list[dict]:
    rows = []
    for model, res in results.items():
        for a, r in res.items():
            for eye, (pk, dur, skew) in r["kinematics"].items():
                rows.append(
                    {
                        "model": model,
                        "amplitude_deg": a,
                        "eye": eye,
                        "peak_velocity_deg_s": round(pk, 1),
                        "duration_ms": round(dur, 2),
                        "skewness": round(skew, 3),
                    }
                )
    return rows


def plot(results: dict[str, dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import models

    fig, ax = plt.subplots(1, 4, figsize=(17, 4.2))
    burst = results["burst"]
    for a in PROFILE_AMPLITUDES_DEG:
        r = burst[a]
        tr, plan = r["trace"], r["plan"]
        t = tr.times_ms - plan.onset_ms
        w = np.degrees(tr.velocities[:, :, 0])
        (line,) = ax[0].plot(t, w[:, 1], lw=1.4, label=f"{a}°")
        ax[0].plot(t, w[:, 0], lw=1.0, ls="--", color=line.get_color())
        if "legacy" in results and a in results["legacy"]:
            rl = results["legacy"][a]
            ax[0].plot(
                rl["trace"].times_ms - rl["plan"].onset_ms,
                np.degrees(rl["trace"].velocities[:, 1, 0]),
                lw=0.7,
                color=line.get_color(),
                alpha=0.35,
            )
    ax[0].set(
        xlim=(-5, 150),
        xlabel="time re burst onset (ms)",
        ylabel="horizontal eye velocity (deg/s)",
        title="velocity profiles: abducting (solid), adducting (dashed),\nlegacy E(t) (faint)",
    )
    ax[0].legend(fontsize=8)
    A = np.linspace(0.5, 52, 200)
    ax[1].plot(A, 525 * (1 - np.exp(-A / 7)), color="0.5", lw=1, label="Van Wetter & Van Opstal 2008")
    ax[1].fill_between([40, 52], 502 - 32, 502 + 32, color="0.85", label="Collewijn et al. 1988: 502±32")
    ax[2].plot(A, 2.2 * A + 21, color="0.5", lw=1, label="Carpenter 1988: 2.2A + 21")
    styles: dict[str, dict[str, Any]] = {
        "burst": dict(marker="o", color="C3"),
        "legacy": dict(marker="s", color="C0", alpha=0.6),
    }
    for model, res in results.items():
        amps = sorted(res)
        for k, col in ((0, 1), (1, 2)):
            for eye, ls in (("right", "-"), ("left", "--")):
                ax[col].plot(
                    amps,
                    [res[a]["kinematics"][eye][k] for a in amps],
                    ls=ls,
                    ms=4,
                    lw=1,
                    label=f"{model}, {'abducting' if eye == 'right' else 'adducting'}",
                    **styles[model],
                )
    ax[1].set(xlabel="amplitude (deg)", ylabel="peak velocity (deg/s)", title="main sequence: peak velocity")
    ax[2].set(xlabel="amplitude (deg)", ylabel="duration (ms, 30 deg/s crossings)", title="main sequence: duration")
    ax[1].legend(fontsize=7)
    ax[2].legend(fontsize=7)
    r = burst[20]
    plan, tr = r["plan"], r["trace"]
    t = np.arange(plan.onset_ms - 250, plan.onset_ms + 300, 1.0)
    true = np.degrees(plan.angles(t)[:, :, 0].mean(axis=1))
    lat = models.VISUAL_LATENCY_MS
    eps_comp = np.degrees(plan.eye_position_signal(t)[:, :, 0].mean(axis=1))
    eps_flash = np.degrees(plan.eye_position_signal(t + lat)[:, :, 0].mean(axis=1))
    rel = t - plan.onset_ms
    ax[3].plot(rel, true, color="k", lw=1.5, label="true eye (version)")
    ax[3].plot(rel, eps_comp, color="C2", lw=1.2, label="eye-position signal at the comparator")
    ax[3].plot(rel, eps_flash, color="C2", lw=1.2, ls="--", label=f"signal paired with a flash at t (t + {lat:.0f} ms)")
    ax[3].set(
        xlabel="time re saccade onset (ms)",
        ylabel="horizontal position (deg)",
        title="eye-position signal, 20° saccade",
    )
    ax[3].legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)


def _screen(values: list[str]):
    """``--screen``: 3 numbers (cm; the resolution from the ASC file) or 5 (px and cm)."""
    from .eyetracking import RecordingError, Screen

    if len(values) not in (3, 5):
        raise argparse.ArgumentTypeError(
            f"--screen takes 3 numbers (WIDTH_CM HEIGHT_CM DISTANCE_CM) or 5 "
            f"(WIDTH_PX HEIGHT_PX WIDTH_CM HEIGHT_CM DISTANCE_CM); got {len(values)}"
        )
    try:
        nums = [float(v) for v in values]
    except ValueError:
        raise argparse.ArgumentTypeError(f"--screen takes numbers; got {' '.join(values)!r}") from None
    if not all(math.isfinite(v) for v in nums):
        raise argparse.ArgumentTypeError(f"--screen takes finite numbers; got {' '.join(values)!r}")
    if len(nums) == 3:
        px: list[int | None] = [None, None]  # resolution from the ASC file (a CSV in pixels needs all five)
    elif any(v != int(v) for v in nums[:2]):
        raise argparse.ArgumentTypeError(
            f"--screen WIDTH_PX HEIGHT_PX must be whole numbers; got {values[0]} {values[1]}"
        )
    else:
        px = [int(v) for v in nums[:2]]
    try:
        return Screen(px[0], px[1], nums[-3], nums[-2], nums[-1])
    except RecordingError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


#: The files ``saccades --recording`` writes into its folder: one recording's results, replaced together.
RECORDING_FILES = ("recording.json", "main_sequence.csv", "main_sequence.png", "generator.json")


def run_recording(args: argparse.Namespace, parser: argparse.ArgumentParser | None = None) -> int:
    """``saccades --recording FILE``: main sequence, fitted generator and figure of a recording (each
    eye in its own sub-folder ``left/``, ``right/`` with ``--eye both``)."""
    from . import eyetracking as et

    def usage(message: str):
        if parser is None:  # called from Python: the error itself
            raise ValueError(message)
        parser.error(message)

    held = getattr(args, "hold", None) or {}
    both = sorted(set(held) & set(args.fit_parameters))
    if both:
        usage(f"argument --hold: {', '.join(both)} cannot be both held and fitted (--fit-parameters)")
    start = None
    if held:
        import models

        try:
            start = models.BurstGenerator(**held)
        except ValueError as e:
            usage(f"argument --hold: {e}")
    args.start_generator = start
    screen = None
    if args.screen is not None:
        try:
            screen = _screen(args.screen)
        except argparse.ArgumentTypeError as e:
            usage(f"argument --screen: {e}")
    path = Path(args.recording)
    eye = getattr(args, "eye", None)
    show = not getattr(args, "no_progress", False)
    stage(f"reading {path} and detecting saccades", enabled=show)
    try:
        recs = et.read_recordings(
            path,
            screen=screen,
            fmt=args.format,
            eye=eye,
            columns=getattr(args, "columns", None),
            preset=getattr(args, "preset", None),
            time_unit=getattr(args, "time_unit", None),
            units=getattr(args, "units", None),
        )
        measured = []
        for rec in recs:
            sacc = et.detect_saccades(rec, args.detect)
            rows = et.main_sequence_rows(rec, sacc)
            if not rows:
                broken = float(np.mean(~rec.ok_steps)) if len(rec.times_ms) > 1 else 0.0
                why = (
                    f"; {100 * broken:.0f} % of the sample intervals differ from the median by more than 25 %: "
                    "irregular time stamps leave no unbroken stretch long enough to measure a saccade"
                    if broken > 0.05
                    else ""
                )
                raise et.RecordingError(
                    f"{path}: no measurable saccades found in the {rec.eye} eye ({len(sacc)} candidate(s) "
                    f"from {'the file events' if rec.file_saccades_ms and args.detect != 'engbert' else 'Engbert-Kliegl detection'}, "
                    f"{len(rec.times_ms)} samples at {rec.rate_hz:g} Hz in {rec.n_blocks} unbroken stretch(es)){why}"
                )
            rows, bad = et.check_plausible(rec, rows)
            measured.append((rec, rows, bad))
    except et.RecordingError as e:
        usage(f"argument --recording: {e}")
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    with path_lock(out / ".lock", f"the folder {out}"):
        codes = []
        for rec, rows, bad in measured:
            folder = out / rec.eye if len(measured) > 1 else out
            folder.mkdir(exist_ok=True)
            codes.append(_write_recording_results(args, path, rec, rows, bad, folder))
        return max(codes)


def _source_identity(path: Path, rec, args) -> dict:
    import hashlib

    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return {
        "file": path.name,
        "sha256": h.hexdigest(),
        "eye": rec.eye,
        "eye_reason": rec.eye_reason,
        "format": rec.fmt,
        "detection": args.detect,
        "held_parameters": dict(getattr(args, "hold", None) or {}),
        "sampling_rate_hz": rec.rate_hz,
        "n_samples": int(len(rec.times_ms)),
        "n_blocks": rec.n_blocks,
        "units": rec.units,
        "screen": None if rec.screen is None else vars(rec.screen),
        "notes": list(rec.notes),
    }


def _claim_folder(out: Path, ident: dict) -> str | None:
    """Make ``out`` this recording's: when it holds another recording's results (or results of an
    unknown one), remove them all first, so that a folder never mixes two recordings' files, even
    if this run is killed; then write ``recording.json``. Returns the replaced file's name, if any."""
    import json

    from ..folders import write_json

    old = out / "recording.json"
    previous = None
    present = [f for f in RECORDING_FILES if (out / f).exists()]
    if present:
        try:
            doc = json.loads(old.read_text()) if old.exists() else {}
        except (OSError, ValueError, RecursionError):
            doc = {}
        same = isinstance(doc, dict) and all(doc.get(k) == ident[k] for k in ("sha256", "eye", "detection"))
        if not same:
            previous = (doc.get("file") if isinstance(doc, dict) else None) or "an unknown recording"
            for f in ("saccades.png",) + RECORDING_FILES[
                ::-1
            ]:  # the manifest last: until then it says whose files remain
                (out / f).unlink(missing_ok=True)
    write_json(out / "recording.json", ident)
    return previous


def _write_recording_results(args, path: Path, rec, rows: list[dict], bad: list[dict], out: Path) -> int:
    """Fit the generator to a recording's ``rows`` and write table, parameters and figure into ``out``."""
    from . import eyetracking as et
    from . import generator_fit as gf

    ident = _source_identity(path, rec, args)
    ident["n_saccades"], ident["n_implausible_dropped"] = len(rows), len(bad)
    replaced = _claim_folder(out, ident)
    if replaced:
        print(f"{out}: replaced the results of {replaced}")
    (out / "generator.json").unlink(missing_ok=True)  # written again only if the fit is identified
    et.write_rows(rows, out / "main_sequence.csv")
    noise = rec.noise_deg
    print(
        f"{path.name}, {rec.eye} eye ({rec.eye_reason}): {len(rec.times_ms)} samples at {rec.rate_hz:g} Hz in "
        f"{rec.n_blocks} unbroken stretch(es), {len(rows)} saccades measured (tracker noise {noise:.3f} deg)"
        + (f"; {len(bad)} implausible saccade(s) dropped" if bad else "")
    )
    need = max(5, 2 * len(args.fit_parameters))
    if len(rows) < need:
        gf.plot_main_sequence(
            rows,
            None,
            out / "main_sequence.png",
            rate_hz=rec.rate_hz,
            noise_deg=noise,
            title=f"{path.name} ({rec.eye}): {len(rows)} saccades at {rec.rate_hz:g} Hz",
        )
        print(
            f"saccades: error: {path.name} ({rec.eye} eye): only {len(rows)} measurable saccade(s); fitting "
            f"{len(args.fit_parameters)} parameters needs at least {need}: no generator.json written",
            file=sys.stderr,
        )
        return 3
    boot = getattr(args, "bootstrap", gf.DEFAULT_BOOTSTRAP)
    stage(
        f"fitting the burst generator ({', '.join(args.fit_parameters)}) to {len(rows)} saccades"
        + (f", {boot} bootstrap refits for the CIs" if boot else ""),
        enabled=not getattr(args, "no_progress", False),
    )
    fit = gf.fit_generator(
        rows,
        fit=args.fit_parameters,
        start=getattr(args, "start_generator", None),
        rate_hz=rec.rate_hz,
        noise_deg=noise,
        bootstrap=getattr(args, "bootstrap", gf.DEFAULT_BOOTSTRAP),
    )
    gf.plot_main_sequence(
        rows,
        fit.generator,
        out / "main_sequence.png",
        rate_hz=rec.rate_hz,
        noise_deg=noise,
        title=f"{path.name} ({rec.eye}): {len(rows)} saccades at {rec.rate_hz:g} Hz",
    )
    for name in fit.fitted:
        lo, hi = fit.ci95[name]
        flag = "  ON A BOUND" if name in fit.at_bounds else ""
        print(f"  {name:18s} {fit.estimates[name]:9.3f}  95% CI [{lo:.4g}, {hi:.4g}]{flag}")
    if fit.problems:
        print(
            f"saccades: error: {path.name} ({rec.eye} eye): the generator is not identified by these "
            f"{len(rows)} saccades ({'; '.join(fit.problems)}): no generator.json written; "
            f"{out / 'main_sequence.csv'} and {out / 'main_sequence.png'} are",
            file=sys.stderr,
        )
        return 3
    fit.to_file(out / "generator.json", **{k: v for k, v in ident.items() if k != "notes"})
    print(f"wrote {out / 'main_sequence.csv'}, {out / 'generator.json'} and {out / 'main_sequence.png'}")
    return 0


def run_models(args: argparse.Namespace, out: Path) -> int:
    """``saccades`` without ``--recording``: the trajectory models' kinematics into ``out`` (table, figure)."""
    if (out / "recording.json").exists():  # a recording's results: replaced whole, never mixed with the model's
        print(f"{out}: replaced the results of a recording with the model's")
        for f in RECORDING_FILES[::-1]:
            (out / f).unlink(missing_ok=True)
    models_ = ("burst", "legacy") if args.model == "both" else (args.model,)
    results = {m: measure(m, progress=not getattr(args, "no_progress", True)) for m in models_}
    rows = main_sequence_rows(results)
    write_csv(out / "main_sequence.csv", list(rows[0]), rows)
    if "burst" in results:
        plot(results, out / "saccades.png")
    print(
        f"{'model':7s} {'amp':>4s}  {'peak (deg/s) abd/add':>21s}  {'duration (ms) abd/add':>22s}  {'skewness abd/add':>17s}"
    )
    for m, res in results.items():
        for a in sorted(res):
            k = res[a]["kinematics"]
            print(
                f"{m:7s} {a:4d}  {k['right'][0]:10.0f} {k['left'][0]:10.0f}  {k['right'][1]:11.1f} {k['left'][1]:10.1f}"
                f"  {k['right'][2]:8.2f} {k['left'][2]:8.2f}"
            )
    print(f"wrote {out / 'main_sequence.csv'}" + (f" and {out / 'saccades.png'}" if "burst" in results else ""))
    return 0
