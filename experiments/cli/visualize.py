"""``python -m experiments visualize``: record a run of the environment in Rerun
(``experiments.recording.record_env_run``), to a file, a native viewer or the web viewer."""

from __future__ import annotations

import argparse
import os
from typing import TYPE_CHECKING

from ..psychophysics.bounds import LIMITS
from .commands import HELP
from .options import (
    ENV_TASKS,
    add_image_size_option,
    add_no_progress_option,
    add_seed_option,
    add_server_options,
    add_task_option,
    digits_in,
)

if TYPE_CHECKING:
    from ..recording import WebViewer

__all__ = ["BOUNDS", "add_subcommand", "run"]

#: Bounds (inclusive) of ``visualize``'s own numeric options.
BOUNDS = {"steps": (1, 100), "fixation_ms": (1, 10_000)}


def _rrd_path(text: str) -> str:
    """argparse type for ``--out``: a file whose folder exists and can be written to."""
    if not str(text).strip():
        raise argparse.ArgumentTypeError("expected a file path such as run.rrd; got ''")
    if "\0" in text:
        raise argparse.ArgumentTypeError(f"the path contains a NUL character: {text!r}")
    path = os.path.abspath(text)
    if os.path.isdir(path):
        raise argparse.ArgumentTypeError(
            f"{text!r} is a directory; give a file such as {os.path.join(text, 'run.rrd')!r}"
        )
    parent = os.path.dirname(path)
    if not os.path.isdir(parent):
        raise argparse.ArgumentTypeError(f"folder {parent!r} does not exist (create it first)")
    existed = os.path.exists(path)
    try:
        with open(path, "ab"):
            pass
    except OSError as e:
        raise argparse.ArgumentTypeError(f"cannot write {text!r}: {e.strerror or e}") from None
    if not existed:
        os.remove(path)
    return text


def add_subcommand(subparsers) -> None:
    """Register ``visualize``."""
    b = BOUNDS
    p = subparsers.add_parser(
        "visualize",
        help=HELP["visualize"],
        description="Run BinocularSaccade-v0 for a few saccades and record the whole pipeline "
        "(the head in its scene in 3-D with each eye's camera and image, eye images with the retina "
        "grid, retina samples, DPFT, cortex, remapping, flashes, eye angles and velocities at every "
        "physics step) on the sim_time timeline. --serve needs no display: it hosts Rerun's web "
        "viewer on 127.0.0.1 and prints the address to open.",
    )
    p.add_argument("--out", type=_rrd_path, default=None, help="write the recording to this .rrd file")
    p.add_argument("--spawn", action="store_true", help="open a native Rerun viewer and stream to it (needs a display)")
    p.add_argument(
        "--serve",
        action="store_true",
        help="host Rerun's web viewer on 127.0.0.1 (loopback only), stream the run to it, print the "
        "address to open in a browser and keep serving until Ctrl-C (no display needed)",
    )
    add_server_options(
        p, "with --serve: ", "with --serve: stop S seconds after the run is recorded (default: serve until Ctrl-C)"
    )
    p.add_argument(
        "--steps",
        type=digits_in(*b["steps"]),
        default=4,
        help=f"number of saccades (env steps) to record, {b['steps'][0]}..{b['steps'][1]} (default 4)",
    )
    seed, size = LIMITS["seed"], LIMITS["image_size"]
    add_seed_option(p, f"seed of the env and of the saccade choices, {seed.lo:d}..{seed.hi:d} (default 0)")
    add_task_option(p, ENV_TASKS)
    p.add_argument(
        "--scene",
        choices=("bar", "dots", "natural", "search"),
        default=None,
        help="scene (default: the task's; fixate uses dots, which has flashes)",
    )
    add_image_size_option(p, f"eye image size in pixels, {size.lo:d}..{size.hi:d} (default 128)", default=128)
    p.add_argument(
        "--fixation-ms",
        type=digits_in(*b["fixation_ms"]),
        default=250,
        help=f"fixation after each saccade, ms, {b['fixation_ms'][0]}..{b['fixation_ms'][1]} (default 250)",
    )
    add_no_progress_option(p, "no progress bar (it goes to stderr)")
    p.set_defaults(func=run, parser=p)


def run(args: argparse.Namespace) -> int:
    """``visualize``: check the options, then record (and serve) the run."""
    from .view import with_viewer  # the web viewer's serving loop, shared with `view`

    _check(args)
    return with_viewer(args, "visualize", (), _visualize)


def _visualize(args: argparse.Namespace, viewer: WebViewer | None) -> list[str]:
    """Record the run (to ``--out``, a native viewer and/or the web viewer); return its summary lines."""
    from ..recording import record_env_run

    p = args.parser
    try:
        summary = record_env_run(
            args.out,
            steps=args.steps,
            seed=args.seed,
            task=args.task,
            scene=args.scene,
            image_size=args.image_size,
            fixation_ms=args.fixation_ms,
            spawn=args.spawn,
            connect=viewer.grpc_url if viewer is not None else None,
            progress=not args.no_progress,
        )
    except (ValueError, FileNotFoundError, KeyError) as e:
        p.error(str(e))
    lines = []
    for i, s in enumerate(summary["saccades"]):
        err = ", ".join(f"{m} {v:.3f}" for m, v in summary["remap_error"][i].items())
        lines.append(
            f"saccade {i + 1}: {s['amplitude_deg']:.1f} deg, peak {s['peak_velocity_deg_s']:.0f} deg/s, "
            f"{s['duration_ms']:.0f} ms; remap error {err}"
        )
    where = " and ".join(
        [
            w
            for w in (args.out, "the viewer" if args.spawn else None, "the web viewer" if viewer is not None else None)
            if w
        ]
    )
    lines.append(f"recorded {summary['start_ms']:.0f}-{summary['end_ms']:.0f} ms of simulated time to {where}")
    return lines


def _check(args: argparse.Namespace) -> None:
    """Usage errors of combinations: --spawn with --serve, nothing to write to, no display, ..."""
    from ..recording.display import _no_display_message, display_available

    p = args.parser
    if args.spawn and args.serve:
        p.error("give --spawn or --serve, not both")
    if args.out is None and not (args.spawn or args.serve):
        p.error("give --out FILE.rrd, --serve (web viewer, no display needed) and/or --spawn")
    if args.spawn and not display_available():
        p.error(_no_display_message("--spawn"))
    if args.serve_seconds is not None and not args.serve:
        p.error("--serve-seconds needs --serve")
