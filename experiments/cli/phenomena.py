"""``python -m experiments phenomena``: which published perisaccadic phenomena each theory predicts
(``experiments.psychophysics.phenomena``, whose docstring is the command's description)."""

from __future__ import annotations

import argparse

from .commands import HELP
from .options import (
    add_backend_options,
    add_generator_option,
    add_image_size_option,
    add_no_progress_option,
    add_quick_option,
    add_workers_option,
    check_backend_options,
    prepare_out,
)
from .parsing import guarded, int_in, out_dir
from .progress import stage

__all__ = ["add_subcommand", "run"]


def add_subcommand(subparsers) -> None:
    """Register ``phenomena``."""
    from ..psychophysics import phenomena

    boot, size = phenomena.BOOT, phenomena.IMAGE_SIZE
    p = subparsers.add_parser(
        "phenomena",
        help=HELP["phenomena"],
        description=phenomena.__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--out", type=out_dir, default="results/phenomena", help="output folder (created; its tables/ are resumed)"
    )
    add_workers_option(p)
    add_backend_options(p)
    add_image_size_option(
        p,
        f"eye image side (default {size}; smaller is faster and adds the retina's sampling error)",
        default=size,
        metavar="PX",
    )
    p.add_argument(
        "--bootstrap",
        type=int_in(100, 100_000),
        default=boot,
        metavar="N",
        help=f"bootstrap resamples per confidence interval (100-100000, default {boot})",
    )
    add_quick_option(
        p,
        "8 flash positions instead of 24, 2 repetitions instead of 4, 7 displacement steps x 6 reports "
        "instead of 13 x 30: a fast look with wider CIs (a folder holds one of the two)",
    )
    add_generator_option(p)
    add_no_progress_option(p, "no progress bars")
    p.set_defaults(func=run, _parser=p)


def run(args: argparse.Namespace) -> int:
    """``phenomena``: one process per folder (a lock), interruptible and resumable, one-line errors."""
    from ..psychophysics.phenomena import measure, write_results
    from ..psychophysics.runner import FolderBusyError, folder_lock

    parser = args._parser
    check_backend_options(args, parser)
    out = prepare_out(args)

    def work() -> int:
        with folder_lock(out):
            tables = measure(
                out,
                workers=args.workers,
                progress=not args.no_progress,
                image_size=args.image_size,
                quick=args.quick,
                generator=args.generator,
                backend=args.backend,
                ray_address=args.ray_address,
            )
            stage(
                "phenomena: scoring each theory (bootstrap CIs), writing the table and figures",
                enabled=not args.no_progress,
            )
            text, figures = write_results(out, tables, args.bootstrap, progress=not args.no_progress)
        print(text, end="")
        print(f"wrote {out / 'phenomena.csv'}, {out / 'phenomena.txt'} and {len(figures)} figures in {out}")
        return 0

    return guarded(
        "python -m experiments phenomena",
        work,
        resume_hint=f"the finished trials are kept in {out}/tables: run the same command again to resume",
        # ValueError: e.g. a tables/ folder holding another configuration
        errors={FolderBusyError: 1, ValueError: 2},
    )
