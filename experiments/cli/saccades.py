"""``python -m experiments saccades``: saccade kinematics against the published main sequence, or a
person's from an eye-tracker recording (``experiments.oculomotor.saccades``, whose docstring is the
command's description)."""

from __future__ import annotations

import argparse
from pathlib import Path

from .commands import HELP
from .options import add_no_progress_option
from .parsing import guarded, out_dir, whole_number

__all__ = ["add_subcommand", "run"]


def _fit_parameters(text: str) -> tuple[str, ...]:
    from ..oculomotor.generator_fit import FITTABLE

    names = tuple(v.strip() for v in text.split(",") if v.strip())
    bad = [n for n in names if n not in FITTABLE]
    if not names or bad or len(set(names)) != len(names):
        raise argparse.ArgumentTypeError(f"expected distinct names among {', '.join(FITTABLE)}; got {text!r}")
    return names


def _hold(text: str) -> dict[str, float]:
    """``NAME=VALUE[,NAME=VALUE]``: generator parameters held at a value instead of their defaults."""
    import math

    from ..oculomotor.generator_fit import FITTABLE

    held: dict[str, float] = {}
    for item in (v.strip() for v in text.split(",") if v.strip()):
        name, sep, value = item.partition("=")
        name = name.strip()
        try:
            number = float(value) if sep else math.nan
        except ValueError:
            number = math.nan
        if name not in FITTABLE or name in held or not math.isfinite(number):
            raise argparse.ArgumentTypeError(
                f"expected NAME=VALUE pairs, distinct names among {', '.join(FITTABLE)} and finite values; got {item!r}"
            )
        held[name] = number
    if not held:
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE pairs; got {text!r}")
    return held


def _columns(text: str):
    from ..oculomotor.tables import TableError, parse_columns

    try:
        return parse_columns(text)
    except TableError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _bootstrap(text: str) -> int:
    n = whole_number(text)
    if n != 0 and not 20 <= n <= 10_000:
        raise argparse.ArgumentTypeError(f"must be 0 (asymptotic CIs) or 20-10000 resamples; got {n}")
    return n


def add_subcommand(subparsers) -> None:
    """Register ``saccades``."""
    from ..oculomotor import saccades
    from ..oculomotor.tables import PRESETS

    p = subparsers.add_parser(
        "saccades",
        help=HELP["saccades"],
        description=saccades.__doc__,
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    p.add_argument("--out", type=out_dir, default="results/saccades", help="output folder (created)")
    p.add_argument(
        "--model",
        choices=("burst", "legacy", "both"),
        default="both",
        help="trajectory model(s) to measure (the figure needs burst)",
    )
    add_no_progress_option(p)
    g = p.add_argument_group("a person's recording (experiments.oculomotor.eyetracking)")
    g.add_argument(
        "--recording",
        metavar="FILE",
        default=None,
        help="EyeLink ASC file or CSV/TSV of samples (time_ms and x_deg,y_deg or x_px,y_px); writes "
        "main_sequence.csv, generator.json and main_sequence.png instead of the model's kinematics",
    )
    g.add_argument("--format", choices=("asc", "csv"), default=None, help="recording format (default: from the suffix)")
    g.add_argument(
        "--screen",
        nargs="+",
        metavar="N",
        default=None,
        help="screen geometry for gaze in pixels: WIDTH_CM HEIGHT_CM DISTANCE_CM (ASC: resolution from "
        "GAZE_COORDS or DISPLAY_COORDS) or WIDTH_PX HEIGHT_PX WIDTH_CM HEIGHT_CM DISTANCE_CM",
    )
    g.add_argument(
        "--eye",
        choices=("left", "right", "both"),
        default=None,
        help="eye to measure (default: the only one recorded, or in a binocular file the one with fewer "
        "lost samples, said in the output); both: each eye into DIR/left and DIR/right",
    )
    g.add_argument(
        "--columns",
        type=_columns,
        default=None,
        metavar="time=NAME,x=NAME,y=NAME[,eye=NAME]",
        help="CSV/TSV: the columns of time and gaze (eye: a column saying L/R per row)",
    )
    g.add_argument(
        "--preset",
        choices=sorted(PRESETS),
        default=None,
        help="CSV/TSV: a documented export layout (default: the one the header matches)",
    )
    g.add_argument(
        "--time-unit",
        choices=("ms", "us", "s"),
        default=None,
        help="CSV/TSV: unit of the time column (default: from the preset or the column name, else ms)",
    )
    g.add_argument(
        "--units",
        choices=("px", "deg"),
        default=None,
        help="CSV/TSV: unit of the gaze columns (default: from the preset or the column name)",
    )
    g.add_argument(
        "--detect",
        choices=("auto", "file", "engbert"),
        default="auto",
        help="saccades: the file's own ESACC events (file), Engbert & Kliegl 2003 detection (engbert), "
        "or the events where the file has them (auto)",
    )
    g.add_argument(
        "--fit-parameters",
        type=_fit_parameters,
        default=("burst_max_deg_s", "burst_scale_deg", "burst_lag_ms"),
        metavar="NAMES",
        help="comma-separated burst-generator parameters to fit (the others keep their defaults, or --hold's values)",
    )
    g.add_argument(
        "--hold",
        type=_hold,
        default=None,
        metavar="NAME=VALUE,...",
        help="burst-generator parameters held at these values, not fitted (within the family's ranges); e.g. "
        "the saturated fit: --fit-parameters burst_max_deg_s,burst_lag_ms --hold burst_scale_deg=0.01",
    )
    g.add_argument(
        "--bootstrap",
        type=_bootstrap,
        default=100,
        metavar="N",
        help="resamples of the saccades behind the 95%% CIs (20-10000, default 100; 0: asymptotic CIs "
        "from the Jacobian only)",
    )
    p.set_defaults(func=run, parser=p)


def run(args: argparse.Namespace) -> int:
    """``saccades``: the model's kinematics, or a person's with ``--recording``; one writer per ``--out``
    folder, every file written atomically, SIGINT/SIGTERM ending it with one line."""
    from ..folders import LockBusyError, path_lock
    from ..oculomotor.saccades import run_models, run_recording

    def work() -> int:
        if args.recording is not None:
            return run_recording(args, args.parser)
        out: Path = args.out
        out.mkdir(parents=True, exist_ok=True)
        with path_lock(out / ".lock", f"the folder {out}"):
            return run_models(args, out)

    return guarded(
        "python -m experiments saccades",
        work,
        resume_hint="files already written are complete; run the command again for the rest",
        errors={LockBusyError: 1},
    )
