"""The ``visualize`` command (``python -m experiments visualize``): :func:`add_subcommand`."""

from __future__ import annotations

import argparse
import os
import signal
import sys

from ..cli.options import ENV_TASKS
from ..psychophysics.bounds import LIMITS
from .display import _no_display_message, display_available
from .env_run import record_env_run
from .web_viewer import WebViewer

#: Bounds of the numeric options of ``visualize`` (inclusive).
#: ``seed`` and ``image_size`` are every command's (``psychophysics.bounds.LIMITS``, ``cli.options``).
OPTION_BOUNDS = {
    "steps": (1, 100),
    "seed": (LIMITS["seed"].lo, LIMITS["seed"].hi),
    "image_size": (LIMITS["image_size"].lo, LIMITS["image_size"].hi),
    "fixation_ms": (1, 10_000),
    "serve_seconds": (1, 7 * 24 * 3600),
    "web_port": (0, 65535),
    "grpc_port": (0, 65535),
}


def _whole(lo: int, hi: int):
    """argparse type: a whole number (decimal digits, no exponent or fraction) in ``lo..hi``."""

    def parse(text: str) -> int:
        try:
            v = int(str(text).strip(), 10)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number in {lo}..{hi}; got {text!r}") from None
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"expected a whole number in {lo}..{hi}; got {text!r}")
        return v

    parse.__name__ = "whole number"
    return parse


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


def _stopped(e: KeyboardInterrupt) -> int:
    """Exit status after Ctrl-C (SIGINT, 130) or SIGTERM (143)."""
    from ..folders import Interrupted

    return 128 + int(e.signum if isinstance(e, Interrupted) else signal.SIGINT)


def _run_visualize(args: argparse.Namespace) -> int:
    _check_visualize(args)
    return _with_viewer(args, "visualize", (), _visualize)


def _run_view(args: argparse.Namespace) -> int:
    return _with_viewer(args, "view", tuple(args.recordings), None)


def _with_viewer(args: argparse.Namespace, name: str, recordings: tuple, work) -> int:
    """Run a serving command: SIGTERM acts as Ctrl-C (``interruptible``), so that the ``finally``
    stops the server however the command ends; serving until stopped is the normal end (exit 0)."""
    from ..folders import interruptible

    prog = f"python -m experiments {name}"
    viewer = None
    serving = False  # from here on a Ctrl-C / SIGTERM is the normal end: the work is done, the server up
    with interruptible():
        try:
            if name == "view" or args.serve:
                try:
                    viewer = WebViewer(args.web_port, args.grpc_port, recordings=recordings)
                except (ValueError, FileNotFoundError) as e:
                    args.parser.error(str(e))
                except RuntimeError as e:
                    print(f"{prog}: error: {e}", file=sys.stderr)
                    return 1
                serving = work is None  # view: serving is all it does, from the moment it can print its address
                until = (
                    "Ctrl-C to stop)"
                    if args.serve_seconds is None
                    else f"for {args.serve_seconds} s{' after the run' if work else ''})"
                )
                print(f"Rerun web viewer: {viewer.url}", flush=True)
                print(
                    f"(serving {', '.join(recordings) + ' ' if recordings else ''}on {viewer.HOST} only, web port "
                    f"{viewer.web_port}, gRPC port {viewer.grpc_port}; {until}",
                    flush=True,
                )
            report = work(args, viewer) if work is not None else []
            if viewer is not None:
                serving = True  # set before the report is printed: a signal after it is the normal end
            for line in report:
                print(line, flush=True)
            if viewer is not None:
                try:
                    viewer.wait(args.serve_seconds)
                except KeyboardInterrupt:
                    print("stopped serving", flush=True)
                except RuntimeError as e:
                    print(f"{prog}: error: {e}", file=sys.stderr)
                    return 1
        except KeyboardInterrupt as e:
            if serving:  # the signal came between the work's end and the wait: still the normal end
                print("stopped serving", flush=True)
                return 0
            print("interrupted", file=sys.stderr)
            return _stopped(e)
        finally:
            if viewer is not None:
                viewer.close()
    return 0


def _visualize(args: argparse.Namespace, viewer: WebViewer | None) -> list[str]:
    """Record the run (to ``--out``, a native viewer and/or the web viewer); return its summary lines."""
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


def _check_visualize(args: argparse.Namespace) -> None:
    p = args.parser
    if args.spawn and args.serve:
        p.error("give --spawn or --serve, not both")
    if args.out is None and not (args.spawn or args.serve):
        p.error("give --out FILE.rrd, --serve (web viewer, no display needed) and/or --spawn")
    if args.spawn and not display_available():
        p.error(_no_display_message("--spawn"))
    if args.serve_seconds is not None and not args.serve:
        p.error("--serve-seconds needs --serve")


def _rrd_file(text: str) -> str:
    """argparse type for ``view``: an existing .rrd file."""
    if not str(text).strip() or "\0" in text:
        raise argparse.ArgumentTypeError(f"expected an .rrd file; got {text!r}")
    if not os.path.isfile(text):
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a file (write one with 'python -m experiments run' or 'visualize --out FILE.rrd')"
        )
    return text


def _add_view(subparsers) -> None:
    p = subparsers.add_parser(
        "view",
        help="open .rrd recordings in Rerun's web viewer on 127.0.0.1 (no display needed)",
        description="Serve .rrd recordings with Rerun's web viewer and gRPC proxy, bound to 127.0.0.1, and print "
        "the address to open in a browser. Ctrl-C or SIGTERM stops the server: no process or port is "
        "left behind (unlike stopping the 'rerun' Python wrapper, which leaves its server running).",
    )
    p.add_argument("recordings", nargs="+", type=_rrd_file, metavar="FILE.rrd", help="recording(s) to open")
    _server_options(p, "", "stop after S seconds (default: serve until Ctrl-C)")
    p.set_defaults(func=_run_view, parser=p)


def _server_options(p: argparse.ArgumentParser, prefix: str, seconds_help: str) -> None:
    """``--serve-seconds``, ``--web-port``, ``--grpc-port`` (``prefix``: e.g. ``"with --serve: "``)."""
    b = OPTION_BOUNDS
    p.add_argument("--serve-seconds", type=_whole(*b["serve_seconds"]), default=None, metavar="S", help=seconds_help)
    p.add_argument(
        "--web-port",
        type=_whole(*b["web_port"]),
        default=9090,
        help=f"{prefix}port of the web viewer on 127.0.0.1 (default 9090; 0: a free one, printed)",
    )
    p.add_argument(
        "--grpc-port",
        type=_whole(*b["grpc_port"]),
        default=9876,
        help=f"{prefix}port of the gRPC proxy the viewer reads from, on 127.0.0.1 (default 9876; 0: a free one)",
    )


def add_subcommand(subparsers) -> None:
    """Register ``visualize`` (record a run of the environment in Rerun) and ``view`` (open
    recordings in the web viewer)."""
    _add_visualize(subparsers)
    _add_view(subparsers)


def _add_visualize(subparsers) -> None:
    b = OPTION_BOUNDS
    p = subparsers.add_parser(
        "visualize",
        help="record a run of the environment in Rerun (--out FILE.rrd, --serve or --spawn)",
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
    _server_options(
        p, "with --serve: ", "with --serve: stop S seconds after the run is recorded (default: serve until Ctrl-C)"
    )
    p.add_argument(
        "--steps",
        type=_whole(*b["steps"]),
        default=4,
        help=f"number of saccades (env steps) to record, {b['steps'][0]}..{b['steps'][1]} (default 4)",
    )
    p.add_argument(
        "--seed",
        type=_whole(*b["seed"]),
        default=0,
        help=f"seed of the env and of the saccade choices, {b['seed'][0]}..{b['seed'][1]} (default 0)",
    )
    p.add_argument("--task", choices=ENV_TASKS, default="fixate", help="env task (default fixate)")
    p.add_argument(
        "--scene",
        choices=("bar", "dots", "natural", "search"),
        default=None,
        help="scene (default: the task's; fixate uses dots, which has flashes)",
    )
    p.add_argument(
        "--image-size",
        type=_whole(*b["image_size"]),
        default=128,
        help=f"eye image size in pixels, {b['image_size'][0]}..{b['image_size'][1]} (default 128)",
    )
    p.add_argument(
        "--fixation-ms",
        type=_whole(*b["fixation_ms"]),
        default=250,
        help=f"fixation after each saccade, ms, {b['fixation_ms'][0]}..{b['fixation_ms'][1]} (default 250)",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar (it goes to stderr)")
    p.set_defaults(func=_run_visualize, parser=p)
