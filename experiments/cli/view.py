"""``python -m experiments view``: serve .rrd recordings with Rerun's web viewer on 127.0.0.1
(``experiments.recording.WebViewer``); :func:`with_viewer` is the serving life cycle ``visualize
--serve`` shares."""

from __future__ import annotations

import argparse
import os
import signal
import sys
from collections.abc import Callable
from typing import Any

from .commands import HELP
from .options import add_server_options

__all__ = ["add_subcommand", "run", "with_viewer"]


def _rrd_file(text: str) -> str:
    """argparse type for ``view``: an existing .rrd file."""
    if not str(text).strip() or "\0" in text:
        raise argparse.ArgumentTypeError(f"expected an .rrd file; got {text!r}")
    if not os.path.isfile(text):
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a file (write one with 'python -m experiments run' or 'visualize --out FILE.rrd')"
        )
    return text


def add_subcommand(subparsers) -> None:
    """Register ``view``."""
    p = subparsers.add_parser(
        "view",
        help=HELP["view"],
        description="Serve .rrd recordings with Rerun's web viewer and gRPC proxy, bound to 127.0.0.1, and print "
        "the address to open in a browser. Ctrl-C or SIGTERM stops the server: no process or port is "
        "left behind (unlike stopping the 'rerun' Python wrapper, which leaves its server running).",
    )
    p.add_argument("recordings", nargs="+", type=_rrd_file, metavar="FILE.rrd", help="recording(s) to open")
    add_server_options(p, "", "stop after S seconds (default: serve until Ctrl-C)")
    p.set_defaults(func=run, parser=p)


def run(args: argparse.Namespace) -> int:
    """``view``: serve the recordings until stopped."""
    return with_viewer(args, "view", tuple(args.recordings), None)


def _stopped(e: KeyboardInterrupt) -> int:
    """Exit status after Ctrl-C (SIGINT, 130) or SIGTERM (143)."""
    from ..folders import Interrupted

    return 128 + int(e.signum if isinstance(e, Interrupted) else signal.SIGINT)


def with_viewer(
    args: argparse.Namespace, name: str, recordings: tuple, work: Callable[[argparse.Namespace, Any], list[str]] | None
) -> int:
    """Run a serving command: SIGTERM acts as Ctrl-C (``interruptible``), so that the ``finally``
    stops the server however the command ends; serving until stopped is the normal end (exit 0)."""
    from ..folders import interruptible
    from ..recording import WebViewer

    prog = f"python -m experiments {name}"
    parser: argparse.ArgumentParser = args.parser
    viewer: WebViewer | None = None
    serving = False  # from here on a Ctrl-C / SIGTERM is the normal end: the work is done, the server up
    with interruptible():
        try:
            if name == "view" or args.serve:
                try:
                    viewer = WebViewer(args.web_port, args.grpc_port, recordings=recordings)
                except (ValueError, FileNotFoundError) as e:
                    parser.error(str(e))
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
