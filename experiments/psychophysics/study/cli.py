"""``python -m experiments run``: the perisaccadic flash-localization study (paper §6.5, Fig. 11).

Runs a design of flash trials through the head's real pipeline (``experiments.psychophysics``)
with a perception model (``--model mechanistic|paper``), a viewing condition (``--condition
references|dark``) and a paradigm (``--paradigm localization|separation|displacement``; the
displacement paradigm writes ``summary`` of psychometric fits and ``psychometric`` instead of the
flash figures and no recording), and writes into ``--out``: ``trials.csv`` and ``trials.parquet`` (one row per trial, each with its
configuration hash and a checksum), ``summary.txt`` and ``summary.csv`` (compression index, peak
time, width, error direction), the figures ``fig11``, ``perceived_vs_time`` and
``compression_vs_time`` (PNG and SVG), ``study.rrd`` (a Rerun recording) and ``run.json`` (design
and configuration). An interrupted run resumes where it stopped when the same command is given
again; one run at a time may use a folder.

Exit status: 0 done; 1 a trial gave NaN where a number was expected, or the folder is in use by
another run; 2 a bad option, or a folder holding another configuration; 130 / 143 interrupted
(Ctrl-C / SIGTERM; the rows written so far are kept: run the same command again to resume).
"""

from __future__ import annotations

import argparse
import math
import shlex
import signal
import sys
from pathlib import Path

from ...cli import GENERATOR_HELP, amplitude_list, bounded, check_path_text, generator_file
from ...cli.options import add_backend_options, add_workers_option, check_backend_options
from ...folders import Interrupted as _Interrupted  # noqa: F401  (SIGINT/SIGTERM in the main thread)
from ...folders import interruptible as _interruptible
from ..bounds import LIMITS, MAX_TRIALS
from .run import NonFiniteResultError, run_study

__all__ = ["add_subcommand"]

PROG = "python -m experiments run"


# ---------------------------------------------------------------------------------------------- option types
_num_type = bounded  # an option bounded by psychophysics.bounds.LIMITS (experiments.cli)
_floats = amplitude_list  # comma-separated saccade amplitudes (deg), checked (experiments.cli)


def _times(text: str) -> tuple[int, ...]:
    """``START:STOP:STEP`` (inclusive) or a comma-separated list of whole ms, within ``LIMITS``."""
    lim = LIMITS["flash_times_ms"]
    usage = (
        f"flash times must be START:STOP:STEP (STEP > 0, STOP >= START) or a list of whole ms, "
        f"each in {lim.text()}; got {text!r}"
    )
    try:
        if ":" in text:
            a, b, s = (int(v) for v in text.split(":"))
            if s <= 0 or b < a or not (lim.contains(a) and lim.contains(b)):
                raise ValueError
            return tuple(range(a, b + 1, s))
        vals = tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(usage) from None
    if not vals or not all(lim.contains(v) for v in vals):
        raise argparse.ArgumentTypeError(usage)
    dup = sorted({v for v in vals if vals.count(v) > 1})
    if dup:
        raise argparse.ArgumentTypeError(
            f"flash time {dup[0]} ms is listed twice in {text!r}; list each once (use --repetitions for more trials)"
        )
    return vals


def _formats(text: str) -> tuple[str, ...]:
    formats = tuple(f.strip().lower() for f in text.split(",") if f.strip())
    if not formats or any(f not in ("png", "svg", "pdf") for f in formats):
        raise argparse.ArgumentTypeError(f"must list png, svg or pdf, comma-separated; got {text!r}")
    return formats


def _out(text: str) -> str:
    if not text.strip():
        raise argparse.ArgumentTypeError("the folder name is empty")
    check_path_text(text)  # NUL characters, names too long for the file system
    return text


def add_subcommand(subparsers) -> None:
    """Register ``run`` (the flash-localization study) on the ``experiments`` command line."""
    p = subparsers.add_parser(
        "run",
        help="perisaccadic flash-localization study (table, figures, summary, Rerun recording)",
        description=__doc__,
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    b = {k: v.text() for k, v in LIMITS.items()}
    p.add_argument(
        "--out", type=_out, default="results", help="output folder (created; a run there is resumed; one run at a time)"
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="reduced design: one 20 deg saccade, 8 flash positions, 7 flash times (about 11 s on 2 idle cores)",
    )
    d = p.add_argument_group("design")
    d.add_argument(
        "--amplitudes",
        type=_floats,
        default=None,
        metavar="DEG,...",
        help=f"saccade amplitudes in deg, each in {b['amplitudes_deg']}, from -A/2 to +A/2 azimuth "
        "(default 12,16,20,24; --quick: 20)",
    )
    d.add_argument(
        "--flash-times",
        type=_times,
        default=None,
        metavar="START:STOP:STEP|MS,...",
        help="flash times re saccade onset, whole ms in [-1000, 1000]; write --flash-times=-100:100:20 "
        "when the value starts with '-' (default -150:150:25; --quick: -150,-100,-50,-25,0,50,150)",
    )
    d.add_argument(
        "--positions",
        choices=("fig11", "morrone"),
        default=None,
        help="flash array: fig11 = 24 dots (6 columns x 4 rows) around the target, morrone = 8 dots "
        "mostly along the saccade path (default fig11; --quick: morrone)",
    )
    d.add_argument(
        "--repetitions",
        type=_num_type("repetitions"),
        default=None,
        help=f"repetitions of every condition, {b['repetitions']} (at most {MAX_TRIALS} trials in all; "
        "default 1, 10 for --paradigm displacement)",
    )
    d.add_argument("--seed", type=_num_type("seed"), default=0, help=f"base seed (trial i uses seed + i), {b['seed']}")
    pm = p.add_argument_group("perception model and condition")
    pm.add_argument(
        "--model",
        choices=("mechanistic", "paper", "population", "observer"),
        default="mechanistic",
        help="observer: optimal (Bayesian) combination of retina, an uncertain eye-position signal and "
        "post-saccadic references (experiments/psychophysics/observer.py); population: a gain field "
        "on the cortical map driven by the saccadic burst, read out by a population code "
        "(population.py); mechanistic: remapping driven by the oculomotor command, read out through "
        "the eye-position signal and post-saccadic references; paper: the log-radius shift with the "
        "set time course below (mechanisms.py)",
    )
    pm.add_argument(
        "--condition",
        choices=("references", "dark"),
        default="references",
        help="references: the target stays lit and a ruler appears after the saccade; dark: black "
        "screen, the target goes off at saccade onset",
    )
    pm.add_argument(
        "--paradigm",
        choices=("localization", "separation", "displacement"),
        default="localization",
        help="localization: one flash per trial; separation: two simultaneous flashes 4 deg apart "
        "along the saccade, each localized (perceived separation vs localization); displacement: "
        "the target steps by -4..4 deg during the saccade, with --flash-times as blank durations "
        "(default 0,250 ms); psychometric functions and thresholds",
    )
    pm.add_argument(
        "--reference-contrast",
        type=_num_type("reference_contrast"),
        default=1.0,
        help=f"contrast (opacity) of the post-saccadic references: the target after onset, the ruler, "
        f"the markers, {b['reference_contrast']}",
    )
    pm.add_argument(
        "--reference-ms",
        type=_num_type("reference_ms"),
        default=1000,
        help=f"how long the post-saccadic references stay on after saccade offset, {b['reference_ms']}",
    )
    pm.add_argument(
        "--target-off-ms",
        type=_num_type("target_off_ms"),
        default=1000,
        help=f"the target goes off this long after saccade onset (negative: before it, a memory-guided "
        f"saccade), {b['target_off_ms']}",
    )
    pm.add_argument(
        "--markers",
        type=_markers_arg,
        default=(),
        metavar="DX,DY;...",
        help="up to 4 extra post-saccadic references, deg from the target, e.g. '-10,0;0,-6'",
    )
    pm.add_argument(
        "--no-ruler",
        action="store_true",
        help="references condition without the ruler (the target and markers are the references)",
    )
    pm.add_argument(
        "--feedback-gain",
        type=_num_type("feedback_gain"),
        default=4.5,
        help=f"mechanistic: remapping gain per deg/ms of eye-position-signal speed, {b['feedback_gain']}",
    )
    pm.add_argument(
        "--reference-weight",
        type=_num_type("reference_weight"),
        default=1.0,
        help=f"mechanistic: weight of the reference-anchored read-out when a reference is seen, "
        f"{b['reference_weight']}",
    )
    pm.add_argument(
        "--stability-tolerance",
        type=_num_type("stability_tolerance"),
        default=0.1,
        help=f"displacement: a target seen at landing this close (x amplitude) is taken as stable, "
        f"{b['stability_tolerance']}",
    )
    pm.add_argument(
        "--report-noise-deg",
        type=_num_type("report_noise_deg"),
        default=0.5,
        help=f"displacement: s.d. of the report noise, {b['report_noise_deg']}",
    )
    pm.add_argument(
        "--disable",
        type=_mechanisms,
        default=(),
        metavar="NAME,...",
        help="mechanistic: switch ingredients off: smear, latency, eye_position_signal, command_remap, references",
    )
    t = p.add_argument_group(
        "remapping gain time course g(t) of --model paper: distances from the target shrink by exp(-g)"
    )
    t.add_argument(
        "--peak-time-ms",
        type=_num_type("peak_time_ms"),
        default=-10.0,
        help=f"time of peak compression re saccade onset, {b['peak_time_ms']}",
    )
    t.add_argument(
        "--rise-ms",
        type=_num_type("rise_ms"),
        default=25.0,
        help=f"s.d. of the rising flank (before the peak), {b['rise_ms']}",
    )
    t.add_argument(
        "--decay-ms",
        type=_num_type("decay_ms"),
        default=30.0,
        help=f"s.d. of the decaying flank (after the peak), {b['decay_ms']}",
    )
    t.add_argument(
        "--peak-gain",
        type=_num_type("peak_gain"),
        default=math.log(2.0),
        help=f"peak log-radius shift, natural-log units, {b['peak_gain']} (ln 2 = 50%% compression; 0 = no remapping)",
    )
    m = p.add_argument_group("model")
    m.add_argument("--image-size", type=_num_type("image_size"), default=256, help=f"eye image side, {b['image_size']}")
    m.add_argument(
        "--fovy-deg",
        type=_num_type("fovy_deg"),
        default=90.0,
        help=f"each eye's vertical field of view, {b['fovy_deg']}",
    )
    m.add_argument(
        "--fovea-deg",
        type=_num_type("fovea_deg"),
        default=2.0,
        help=f"foveal radius of the retina, {b['fovea_deg']} (under a quarter of --fovy-deg)",
    )
    m.add_argument(
        "--oversample",
        type=_num_type("oversample"),
        default=3,
        help=f"density factor of the target-centred read-out grid, {b['oversample']}",
    )
    m.add_argument(
        "--threshold",
        type=_num_type("threshold"),
        default=0.2,
        help=f"read-out: ignore activity below this fraction of the peak, {b['threshold']}",
    )
    m.add_argument(
        "--flash-radius-deg",
        type=_num_type("flash_radius_deg"),
        default=1.0,
        help=f"radius of the flashed dot, {b['flash_radius_deg']}",
    )
    m.add_argument(
        "--endpoint-noise",
        type=_num_type("endpoint_noise"),
        default=0.0,
        help=f"saccade endpoint noise, s.d. as a fraction of the amplitude, {b['endpoint_noise']} (seeded per trial)",
    )
    m.add_argument(
        "--saccade-model",
        choices=("burst", "legacy"),
        default="burst",
        help="saccade trajectories: the brainstem burst generator or the legacy main-sequence planner",
    )
    m.add_argument("--generator", type=generator_file, default=None, metavar="FILE", help=GENERATOR_HELP)
    m.add_argument(
        "--eye-drive",
        choices=("plant", "servo"),
        default="plant",
        help="how the eyes move: torques through the orbital plant (default) or the exact-pointing servo",
    )
    m.add_argument(
        "--eye-position",
        choices=("signal", "true"),
        default="signal",
        help="read-out from retina to head: the extraretinal eye-position signal (slow, from the "
        "efference copy) or the true eye orientation (an oracle, for comparison)",
    )
    m.add_argument(
        "--visual-latency-ms",
        type=_num_type("visual_latency_ms"),
        default=70.0,
        help=f"delay from a flash to its cortical response, {b['visual_latency_ms']}: the flash is "
        "read with the eye-position signal this much later",
    )
    r = p.add_argument_group("execution and output")
    add_workers_option(r)
    add_backend_options(r)
    r.add_argument(
        "--formats", type=_formats, default="png,svg", help="figure formats, comma-separated (png, svg, pdf)"
    )
    r.add_argument("--no-recording", action="store_true", help="do not write study.rrd")
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_handler, _parser=p)


#: The displacement paradigm's target steps (deg along the saccade) and blank durations (ms).
DISPLACEMENT_STEPS_DEG = (-4.0, -3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0, 4.0)
DISPLACEMENT_BLANKS_MS = (0, 250)


def _markers_arg(text: str) -> tuple[tuple[float, float], ...]:
    """``--markers DX,DY;DX,DY``: marker offsets from the target (deg)."""
    out = []
    for part in (p.strip() for p in text.split(";") if p.strip()):
        try:
            dx, dy = (float(v) for v in part.split(","))
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected DX,DY pairs separated by ';' (deg from the target); got {part!r}"
            ) from None
        out.append((dx, dy))
    return tuple(out)


def _mechanisms(text: str) -> tuple[str, ...]:
    from ..mechanisms import MECHANISMS

    names = tuple(n.strip() for n in text.split(",") if n.strip())
    bad = [n for n in names if n not in MECHANISMS]
    if bad or not names:
        raise argparse.ArgumentTypeError(f"expected mechanism names from {', '.join(MECHANISMS)}; got {text!r}")
    return names


_NOTHING_AFTER_DARK = "in --condition dark nothing is shown after the saccade (use --condition references)"
_NOT_PAPER = "the remapping time course is --model paper's; the other models do not read it"


def _pointless_rules(args: argparse.Namespace) -> list[tuple[str, str, bool, str]]:
    """(dest, option, does nothing now, why) for every option that one condition, paradigm or model ignores."""
    dark, model = args.condition == "dark", args.model
    return [
        ("markers", "--markers", dark, _NOTHING_AFTER_DARK),
        ("no_ruler", "--no-ruler", dark, _NOTHING_AFTER_DARK),
        ("reference_contrast", "--reference-contrast", dark, _NOTHING_AFTER_DARK),
        ("reference_ms", "--reference-ms", dark, _NOTHING_AFTER_DARK),
        (
            "target_off_ms",
            "--target-off-ms",
            dark and getattr(args, "target_off_ms", -1) >= 0,
            "in --condition dark the target goes off at saccade onset (a negative value, before onset, still applies)",
        ),
        ("feedback_gain", "--feedback-gain", model != "mechanistic", "it is --model mechanistic's"),
        ("reference_weight", "--reference-weight", model != "mechanistic", "it is --model mechanistic's"),
        ("disable", "--disable", model != "mechanistic", "it switches off --model mechanistic's ingredients"),
        ("peak_time_ms", "--peak-time-ms", model != "paper", _NOT_PAPER),
        ("rise_ms", "--rise-ms", model != "paper", _NOT_PAPER),
        ("decay_ms", "--decay-ms", model != "paper", _NOT_PAPER),
        ("peak_gain", "--peak-gain", model != "paper", _NOT_PAPER),
        (
            "stability_tolerance",
            "--stability-tolerance",
            args.paradigm != "displacement",
            "it is --paradigm displacement's",
        ),
        ("report_noise_deg", "--report-noise-deg", args.paradigm != "displacement", "it is --paradigm displacement's"),
    ]


def _refuse_pointless(args: argparse.Namespace, parser: argparse.ArgumentParser) -> None:
    """A usage error for an option given a value other than its default where the chosen condition,
    paradigm or model ignores it (it would change the configuration's hash and nothing else)."""
    for dest, option, pointless, why in _pointless_rules(args):
        default = parser.get_default(dest)
        if pointless and hasattr(args, dest) and getattr(args, dest) != default:
            parser.error(f"argument {option}: does nothing here: {why}")


def _build(args: argparse.Namespace):
    """The design and configuration of the command line; ``argparse`` usage errors name the option."""
    from .. import FIG11_OFFSETS_DEG, MORRONE_OFFSETS_DEG, Design, RemapTimeCourse, TrialConfig

    parser = args._parser
    base = (
        dict(amplitudes_deg=(20.0,), flash_times_ms=(-150, -100, -50, -25, 0, 50, 150), positions="morrone")
        if args.quick
        else dict(
            amplitudes_deg=(12.0, 16.0, 20.0, 24.0), flash_times_ms=tuple(range(-150, 151, 25)), positions="fig11"
        )
    )
    positions = args.positions or base["positions"]
    amps = args.amplitudes or base["amplitudes_deg"]
    times = args.flash_times or base["flash_times_ms"]
    offsets = FIG11_OFFSETS_DEG if positions == "fig11" else MORRONE_OFFSETS_DEG
    reps = args.repetitions
    if args.paradigm == "displacement":  # target steps along the saccade x blank durations
        if args.positions:
            parser.error("argument --positions: the displacement paradigm has target steps, not flash positions")
        offsets = tuple((s, 0.0) for s in DISPLACEMENT_STEPS_DEG)
        times = args.flash_times or DISPLACEMENT_BLANKS_MS
        if any(t < 0 for t in times):
            parser.error("argument --flash-times: in the displacement paradigm these are blank durations, ms >= 0")
        reps = reps or 10
    reps = reps or 1
    _refuse_pointless(args, parser)
    n = len(amps) * len(offsets) * len(times) * reps
    if n > MAX_TRIALS:
        parser.error(
            f"argument --repetitions: the design would have {n} trials, more than {MAX_TRIALS}; lower "
            "--repetitions or give fewer --amplitudes or --flash-times"
        )
    if args.fovea_deg >= args.fovy_deg / 4:
        parser.error(
            f"argument --fovea-deg: must be less than a quarter of --fovy-deg ({args.fovy_deg:g}); "
            f"got {args.fovea_deg:g}"
        )
    try:
        design = Design(
            amplitudes_deg=amps,
            flash_offsets_deg=offsets,
            flash_times_ms=times,
            repetitions=reps,
            seed=args.seed,
            name="quick" if args.quick else "default",
        )
        tc = RemapTimeCourse(args.peak_time_ms, args.rise_ms, args.decay_ms, args.peak_gain)
        config = TrialConfig(
            image_size=args.image_size,
            fovy_deg=args.fovy_deg,
            fovea_deg=args.fovea_deg,
            timecourse=tc,
            threshold=args.threshold,
            endpoint_noise=args.endpoint_noise,
            oversample=args.oversample,
            flash_radius_deg=args.flash_radius_deg,
            saccade_model=args.saccade_model,
            generator=args.generator,
            eye_drive=args.eye_drive,
            eye_position=args.eye_position,
            visual_latency_ms=args.visual_latency_ms,
            model=args.model,
            condition=args.condition,
            paradigm=args.paradigm,
            feedback_gain=args.feedback_gain,
            reference_weight=args.reference_weight,
            disabled=args.disable,
            stability_tolerance=args.stability_tolerance,
            report_noise_deg=args.report_noise_deg,
            reference_contrast=getattr(args, "reference_contrast", 1.0),
            reference_ms=getattr(args, "reference_ms", 1000),
            target_off_ms=getattr(args, "target_off_ms", 1000),
            markers=getattr(args, "markers", ()),
            ruler=not getattr(args, "no_ruler", False),
        )
    except (ValueError, TypeError) as e:
        parser.error(str(e))
    return design, config, args.formats


# ---------------------------------------------------------------------------------------------- command
def _command(args: argparse.Namespace) -> str:
    """The command line that gives the same run (options at their defaults left out)."""
    parser = args._parser
    words = PROG.split()

    def text(v) -> str:
        if isinstance(v, (tuple, list)):
            return ",".join(text(x) for x in v)
        if isinstance(v, float):
            return str(int(v)) if v.is_integer() else repr(v)
        return str(v)

    for a in parser._actions:
        if not a.option_strings or a.dest in ("help",) or a.dest.startswith("_"):
            continue
        v = getattr(args, a.dest, None)
        default = a.type(a.default) if isinstance(a.default, str) and a.type else a.default
        opt = max(a.option_strings, key=len)
        if v == default and a.dest != "out":
            continue
        if a.nargs == 0:  # store_true
            words.append(opt)
            continue
        s = text(v)
        words += [f"{opt}={s}"] if s.startswith("-") else [opt, s]
    return shlex.join(words)


def _saved(csv_path: Path) -> int:
    import warnings

    from .. import read_table

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return len(read_table(csv_path, partial=True)["trial_id"])
    except Exception:  # noqa: BLE001 - only for the message
        return 0


def _handler(args: argparse.Namespace) -> int:
    parser = args._parser
    from ..runner import FolderBusyError, OutputFolderError, prepare_output_folder

    check_backend_options(args, parser)
    design, config, formats = _build(args)
    try:
        out = prepare_output_folder(args.out)
    except (OutputFolderError, TypeError) as e:
        parser.error(f"argument --out: {e}")
    csv_path = out / "trials.csv"
    try:
        with _interruptible():
            res = run_study(
                design,
                config,
                out,
                workers=args.workers,
                progress=not args.no_progress,
                formats=formats,
                recording=not args.no_recording,
                backend=args.backend,
                ray_address=args.ray_address,
            )
    except KeyboardInterrupt as e:
        signum = getattr(e, "signum", signal.SIGINT)
        print(
            f"{PROG}: interrupted ({signal.Signals(signum).name}) with {_saved(csv_path)} of {design.n_trials} "
            f"trials saved in {csv_path}; to resume, run the same command again: {_command(args)}",
            file=sys.stderr,
        )
        return 128 + int(signum)
    except OutputFolderError as e:
        parser.error(f"argument --out: {e}")
    except (FolderBusyError, NonFiniteResultError) as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return 1
    except ValueError as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return 1
    print(res["summary"], end="")
    print(
        f"wrote {res['table']}, {len(res['figures'])} figures"
        + (f", {res['recording']}" if res["recording"] else "")
        + f" in {out}"
    )
    return 0
