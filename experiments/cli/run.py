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
import shlex
import signal
import sys
from pathlib import Path

from ..folders import Interrupted as _Interrupted  # noqa: F401  (SIGINT/SIGTERM in the main thread)
from ..folders import interruptible as _interruptible
from ..psychophysics.bounds import LIMITS, MAX_TRIALS
from .commands import HELP
from .options import (
    add_backend_options,
    add_generator_option,
    add_no_progress_option,
    add_quick_option,
    add_seed_option,
    add_workers_option,
    check_backend_options,
    prepare_out,
)
from .parsing import amplitude_list, bounded, check_path_text
from .trialconfig import add_trial_options, field_default, trial_values

__all__ = ["add_subcommand", "run"]

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


#: run's options of ``TrialConfig``'s fields, by group: field -> help (``{range}``: the field's
#: range from ``LIMITS``, else appended); defaults, ranges and choices come from the fields.
PERCEPTION_FIELDS = {
    "model": "observer: optimal (Bayesian) combination of retina, an uncertain eye-position signal and "
    "post-saccadic references (experiments/psychophysics/observer.py); population: a gain field "
    "on the cortical map driven by the saccadic burst, read out by a population code "
    "(population.py); mechanistic: remapping driven by the oculomotor command, read out through "
    "the eye-position signal and post-saccadic references; paper: the log-radius shift with the "
    "set time course below (mechanisms.py)",
    "condition": "references: the target stays lit and a ruler appears after the saccade; dark: black "
    "screen, the target goes off at saccade onset",
    "paradigm": "localization: one flash per trial; separation: two simultaneous flashes 4 deg apart "
    "along the saccade, each localized (perceived separation vs localization); displacement: "
    "the target steps by -4..4 deg during the saccade, with --flash-times as blank durations "
    "(default 0,250 ms); psychometric functions and thresholds",
    "reference_contrast": "contrast (opacity) of the post-saccadic references: the target after onset, the ruler, "
    "the markers",
    "reference_ms": "how long the post-saccadic references stay on after saccade offset",
    "target_off_ms": "the target goes off this long after saccade onset (negative: before it, a memory-guided saccade)",
}
MECHANISTIC_FIELDS = {
    "feedback_gain": "mechanistic: remapping gain per deg/ms of eye-position-signal speed",
    "reference_weight": "mechanistic: weight of the reference-anchored read-out when a reference is seen",
    "stability_tolerance": "displacement: a target seen at landing this close (x amplitude) is taken as stable",
    "report_noise_deg": "displacement: s.d. of the report noise",
}
TIMECOURSE_FIELDS = {
    "peak_time_ms": "time of peak compression re saccade onset",
    "rise_ms": "s.d. of the rising flank (before the peak)",
    "decay_ms": "s.d. of the decaying flank (after the peak)",
    "peak_gain": "peak log-radius shift, natural-log units, {range} (ln 2 = 50%% compression; 0 = no remapping)",
}
MODEL_FIELDS = {
    "image_size": "eye image side",
    "fovy_deg": "each eye's vertical field of view",
    "fovea_deg": "foveal radius of the retina, {range} (under a quarter of --fovy-deg)",
    "oversample": "density factor of the target-centred read-out grid",
    "threshold": "read-out: ignore activity below this fraction of the peak",
    "flash_radius_deg": "radius of the flashed dot",
    "endpoint_noise": "saccade endpoint noise, s.d. as a fraction of the amplitude, {range} (seeded per trial)",
    "saccade_model": "saccade trajectories: the brainstem burst generator or the legacy main-sequence planner",
}
DRIVE_FIELDS = {
    "eye_drive": "how the eyes move: torques through the orbital plant (default) or the exact-pointing servo",
    "eye_position": "read-out from retina to head: the extraretinal eye-position signal (slow, from the "
    "efference copy) or the true eye orientation (an oracle, for comparison)",
    "visual_latency_ms": "delay from a flash to its cortical response, {range}: the flash is "
    "read with the eye-position signal this much later",
}
#: ``TrialConfig``'s fields run sets from options of their own form (not generated).
OWN_FORM = {"markers": "--markers", "ruler": "--no-ruler", "disabled": "--disable", "generator": "--generator"}
#: ``TrialConfig``'s fields run leaves at their defaults.
NOT_OPTIONS = ("reference_unit", "eps_sigma_ms", "eps_delay_ms", "observer", "population")
#: Every field run reads from a generated option.
RUN_FIELDS = (*PERCEPTION_FIELDS, *MECHANISTIC_FIELDS, *TIMECOURSE_FIELDS, *MODEL_FIELDS, *DRIVE_FIELDS)


def add_subcommand(subparsers) -> None:
    """Register ``run`` (the flash-localization study) on the ``experiments`` command line."""
    p = subparsers.add_parser(
        "run",
        help=HELP["run"],
        description=__doc__,
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    b = {k: v.text() for k, v in LIMITS.items()}
    p.add_argument(
        "--out", type=_out, default="results", help="output folder (created; a run there is resumed; one run at a time)"
    )
    add_quick_option(
        p, "reduced design: one 20 deg saccade, 8 flash positions, 7 flash times (about 11 s on 2 idle cores)"
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
    add_seed_option(d, f"base seed (trial i uses seed + i), {b['seed']}")
    pm = p.add_argument_group("perception model and condition")
    add_trial_options(pm, PERCEPTION_FIELDS)
    pm.add_argument(
        "--markers",
        type=_markers_arg,
        default=field_default("markers"),
        metavar="DX,DY;...",
        help="up to 4 extra post-saccadic references, deg from the target, e.g. '-10,0;0,-6'",
    )
    pm.add_argument(
        "--no-ruler",
        action="store_true",
        help="references condition without the ruler (the target and markers are the references)",
    )
    add_trial_options(pm, MECHANISTIC_FIELDS)
    pm.add_argument(
        "--disable",
        type=_mechanisms,
        default=field_default("disabled"),
        metavar="NAME,...",
        help="mechanistic: switch ingredients off: smear, latency, eye_position_signal, command_remap, references",
    )
    t = p.add_argument_group(
        "remapping gain time course g(t) of --model paper: distances from the target shrink by exp(-g)"
    )
    add_trial_options(t, TIMECOURSE_FIELDS)
    m = p.add_argument_group("model")
    add_trial_options(m, MODEL_FIELDS)
    add_generator_option(m)
    add_trial_options(m, DRIVE_FIELDS)
    r = p.add_argument_group("execution and output")
    add_workers_option(r, default=None)
    add_backend_options(r)
    r.add_argument(
        "--formats", type=_formats, default="png,svg", help="figure formats, comma-separated (png, svg, pdf)"
    )
    r.add_argument("--no-recording", action="store_true", help="do not write study.rrd")
    add_no_progress_option(r, "no progress bar")
    p.set_defaults(func=run, _parser=p)


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
    from ..psychophysics.mechanisms import MECHANISMS

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
    from ..psychophysics import FIG11_OFFSETS_DEG, MORRONE_OFFSETS_DEG, Design, RemapTimeCourse, TrialConfig

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
        values = trial_values(args, RUN_FIELDS)
        tc = RemapTimeCourse(**{k: values.pop(k) for k in TIMECOURSE_FIELDS})
        config = TrialConfig(
            **values,
            timecourse=tc,
            generator=args.generator,
            disabled=args.disable,
            markers=args.markers,
            ruler=not args.no_ruler,
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

    from ..psychophysics import read_table

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return len(read_table(csv_path, partial=True)["trial_id"])
    except Exception:  # noqa: BLE001 - only for the message
        return 0


def run(args: argparse.Namespace) -> int:
    """``run``: the study of the options into ``--out`` (``psychophysics.study.run_study``)."""
    from ..psychophysics.runner import FolderBusyError, OutputFolderError
    from ..psychophysics.study.run import NonFiniteResultError, run_study

    parser = args._parser

    check_backend_options(args, parser)
    design, config, formats = _build(args)
    out = prepare_out(args)
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
