"""``python -m experiments run``: the perisaccadic flash-localization study (paper §6.5, Fig. 11).

Runs a design of flash trials through the head's real pipeline (``experiments.psychophysics``)
and writes into ``--out``: ``trials.csv`` and ``trials.parquet`` (one row per trial),
``summary.txt`` and ``summary.csv`` (compression index, peak time, width, error direction),
the figures ``fig11``, ``perceived_vs_time`` and ``compression_vs_time`` (PNG and SVG),
``study.rrd`` (a Rerun recording) and ``run.json`` (design and configuration). An interrupted
run resumes where it stopped when the same command is given again.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path

import numpy as np

__all__ = ["add_subcommand", "run_study", "record_study"]


def _floats(text: str) -> tuple[float, ...]:
    try:
        vals = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from None
    if not vals:
        raise argparse.ArgumentTypeError("expected at least one number")
    return vals


def _times(text: str) -> tuple[int, ...]:
    """``START:STOP:STEP`` (inclusive) or a comma-separated list of whole ms."""
    try:
        if ":" in text:
            a, b, s = (int(v) for v in text.split(":"))
            if s <= 0 or b < a:
                raise ValueError
            return tuple(range(a, b + 1, s))
        vals = tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"flash times must be START:STOP:STEP (STEP > 0, STOP >= START) or a list of whole ms; got {text!r}"
        ) from None
    if not vals:
        raise argparse.ArgumentTypeError("expected at least one flash time")
    return vals


def add_subcommand(subparsers) -> None:
    """Register ``run`` (the flash-localization study) on the ``experiments`` command line."""
    p = subparsers.add_parser(
        "run", help="perisaccadic flash-localization study (table, figures, summary, Rerun recording)",
        description=__doc__, formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--out", default="results", help="output folder (created; a run there is resumed)")
    p.add_argument("--quick", action="store_true",
                   help="reduced design: one 20 deg saccade, 8 flash positions, 7 flash times (about a minute)")
    d = p.add_argument_group("design")
    d.add_argument("--amplitudes", type=_floats, default=None, metavar="DEG,...",
                   help="saccade amplitudes in deg, each from -A/2 to +A/2 azimuth (default 12,16,20,24; --quick: 20)")
    d.add_argument("--flash-times", type=_times, default=None, metavar="START:STOP:STEP|MS,...",
                   help="flash times re saccade onset, ms; write --flash-times=-100:100:20 when the value starts with '-' "
                        "(default -150:150:25; --quick: -150,-100,-50,-25,0,50,150)")
    d.add_argument("--positions", choices=("fig11", "morrone"), default=None,
                   help="flash array: fig11 = 24 dots (6 columns x 4 rows) around the target, morrone = 8 dots "
                        "mostly along the saccade path (default fig11; --quick: morrone)")
    d.add_argument("--repetitions", type=int, default=1, help="repetitions of every condition")
    d.add_argument("--seed", type=int, default=0, help="base seed (trial i uses seed + i)")
    t = p.add_argument_group("remapping gain time course g(t): distances from the target shrink by exp(-g)")
    t.add_argument("--peak-time-ms", type=float, default=-10.0, help="time of peak compression re saccade onset")
    t.add_argument("--rise-ms", type=float, default=25.0, help="s.d. of the rising flank (before the peak)")
    t.add_argument("--decay-ms", type=float, default=30.0, help="s.d. of the decaying flank (after the peak)")
    t.add_argument("--peak-gain", type=float, default=math.log(2.0),
                   help="peak log-radius shift, natural-log units (ln 2 = 50%% compression; 0 = no remapping)")
    m = p.add_argument_group("model")
    m.add_argument("--image-size", type=int, default=256, help="eye image side, pixels")
    m.add_argument("--fovy-deg", type=float, default=90.0, help="each eye's vertical field of view, deg")
    m.add_argument("--fovea-deg", type=float, default=2.0, help="foveal radius of the retina, deg")
    m.add_argument("--oversample", type=int, default=3, help="density factor of the target-centred read-out grid")
    m.add_argument("--threshold", type=float, default=0.2, help="read-out: ignore activity below this fraction of the peak")
    m.add_argument("--flash-radius-deg", type=float, default=1.0, help="radius of the flashed dot, deg")
    m.add_argument("--endpoint-noise", type=float, default=0.0,
                   help="saccade endpoint noise, s.d. as a fraction of the amplitude (seeded per trial)")
    r = p.add_argument_group("execution and output")
    r.add_argument("--workers", type=int, default=2, help="worker processes (spawn context); 1 = in-process")
    r.add_argument("--formats", default="png,svg", help="figure formats, comma-separated (png, svg, pdf)")
    r.add_argument("--no-recording", action="store_true", help="do not write study.rrd")
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_handler, _parser=p)


def _build(args: argparse.Namespace):
    from .psychophysics import FIG11_OFFSETS_DEG, MORRONE_OFFSETS_DEG, Design, RemapTimeCourse, TrialConfig

    base = dict(amplitudes_deg=(20.0,), flash_times_ms=(-150, -100, -50, -25, 0, 50, 150), positions="morrone") \
        if args.quick else dict(amplitudes_deg=(12.0, 16.0, 20.0, 24.0), flash_times_ms=tuple(range(-150, 151, 25)),
                                positions="fig11")
    positions = args.positions or base["positions"]
    design = Design(
        amplitudes_deg=args.amplitudes or base["amplitudes_deg"],
        flash_offsets_deg=FIG11_OFFSETS_DEG if positions == "fig11" else MORRONE_OFFSETS_DEG,
        flash_times_ms=args.flash_times or base["flash_times_ms"],
        repetitions=args.repetitions, seed=args.seed, name="quick" if args.quick else "default")
    tc = RemapTimeCourse(args.peak_time_ms, args.rise_ms, args.decay_ms, args.peak_gain)
    config = TrialConfig(image_size=args.image_size, fovy_deg=args.fovy_deg, fovea_deg=args.fovea_deg,
                         timecourse=tc, threshold=args.threshold, endpoint_noise=args.endpoint_noise,
                         oversample=args.oversample, flash_radius_deg=args.flash_radius_deg)
    formats = tuple(f.strip().lower() for f in args.formats.split(",") if f.strip())
    bad = [f for f in formats if f not in ("png", "svg", "pdf")]
    if not formats or bad:
        raise ValueError(f"--formats must list png, svg or pdf; got {args.formats!r}")
    if args.workers < 1:
        raise ValueError(f"--workers must be >= 1; got {args.workers}")
    return design, config, formats


def record_study(path: Path, table: dict, config, amplitude_deg: float | None = None) -> Path:
    """A Rerun recording of the study: per flash time (sim time = onset + t), all flashes' true and
    perceived positions of one amplitude, the compression index and gain, and one example
    trial's eye images, retina, DPFT and cortex (``experiments.recording.Recorder``)."""
    import rerun as rr

    from .psychophysics import Trial, TrialRunner, compression_index
    from .psychophysics.trial import FIXATION_MS
    from .recording import Recorder

    amps = np.unique(table["saccade_amplitude_deg"])
    a = float(amps[np.argmin(np.abs(amps - 20))]) if amplitude_deg is None else float(amplitude_deg)
    ci = compression_index(table)
    sel = table["saccade_amplitude_deg"] == a
    times = np.unique(table["flash_time_ms"][sel])
    dx0 = float(table["flash_dx_deg"][sel][np.argmin(np.abs(table["flash_dx_deg"][sel] + 8))])
    dy0 = float(table["flash_dy_deg"][sel & (table["flash_dx_deg"] == dx0)][0])
    runner = TrialRunner(config)
    flip = np.array([1.0, -1.0])
    try:
        with Recorder(path, app_id="conformal_head_study") as rec:
            for i, t in enumerate(times):
                trial = Trial(10**6 + i, a, dx0, dy0, int(t), 0, 10**6 + i)
                row = runner.run(trial)
                rec.set_time_ms(row["flash_sim_ms"])
                last = runner.last
                rec.log_head(runner.head)
                rec.log_frame(last["frame"], runner.retina_grid)
                rec.log_views([mp[0] for mp in last["maps"]], runner.retina_grid)
                rec.log_flash((row["true_x_deg"], row["true_y_deg"]), (row["perceived_x_deg"], row["perceived_y_deg"]))
                plan = last["plan"]
                rec.log_eye_angles(plan.angles(row["flash_sim_ms"]), plan.velocities(row["flash_sim_ms"]) * 1000.0)
                m = sel & (table["flash_time_ms"] == t)
                tr = np.column_stack([table["true_x_deg"][m], table["true_y_deg"][m]]) * flip
                pe = np.column_stack([table["perceived_x_deg"][m], table["perceived_y_deg"][m]]) * flip
                rec.log("study/true", rr.Points2D(tr, radii=0.3, colors=[[40, 200, 40]]))
                rec.log("study/perceived", rr.Points2D(pe, radii=0.3, colors=[[230, 40, 40]]))
                rec.log("study/error", rr.Arrows2D(vectors=pe - tr, origins=tr, colors=[[200, 200, 200]]))
                rec.log("study/gain", rr.Scalars(config.timecourse.gain(float(t))))
                for amp, (tt, vals) in ci.items():
                    k = np.nonzero(tt == t)[0]
                    if k.size:
                        rec.log(f"study/compression_index/{amp:g}deg", rr.Scalars(float(vals[k[0]])))
            _ = FIXATION_MS
    finally:
        runner.close()
    return path


def run_study(design, config, out: Path, *, workers: int = 2, progress: bool = True,
              formats: tuple[str, ...] = ("png", "svg"), recording: bool = True) -> dict:
    """Run (or resume) the design, then write summary, figures and the recording into ``out``."""
    from .psychophysics import format_summary, read_table, run_trials, save_all, summary

    csv_path = run_trials(design, config, out, workers=workers, progress=progress)
    table = read_table(csv_path)
    rows = summary(table)
    text = format_summary(rows, config.timecourse, n_trials=len(table["trial_id"]))
    (out / "summary.txt").write_text(text)
    with (out / "summary.csv").open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    figures = save_all(table, out, config.timecourse, formats)
    rrd = record_study(out / "study.rrd", table, config) if recording else None
    return {"table": csv_path, "summary": text, "figures": figures, "recording": rrd}


def _handler(args: argparse.Namespace) -> int:
    parser = args._parser
    try:
        design, config, formats = _build(args)
    except (ValueError, TypeError) as e:
        parser.error(str(e))
    out = Path(args.out)
    try:
        res = run_study(design, config, out, workers=args.workers, progress=not args.no_progress,
                        formats=formats, recording=not args.no_recording)
    except ValueError as e:
        print(f"python -m experiments run: error: {e}", file=sys.stderr)
        return 2
    print(res["summary"], end="")
    print(f"wrote {res['table']}, {len(res['figures'])} figures"
          + (f", {res['recording']}" if res["recording"] else "") + f" in {out}")
    return 0
