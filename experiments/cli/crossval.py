"""``python -m experiments crossval``: cross-validation by condition (``experiments.modelfit.crossval``,
whose docstring is the command's description)."""

from __future__ import annotations

import argparse

from .commands import HELP
from .fitting import model_names
from .options import (
    add_backend_options,
    add_image_size_option,
    add_max_evals_option,
    add_no_progress_option,
    add_noise_deg_option,
    add_quick_option,
    add_reports_option,
    add_seed_option,
    add_workers_option,
    check_backend_options,
    prepare_out,
)
from .parsing import guarded, out_dir

__all__ = ["add_subcommand", "run"]


def run(args: argparse.Namespace) -> int:
    """``crossval``: :func:`experiments.modelfit.crossval.crossvalidate` into ``--out``; prints the summary."""
    from ..folders import LockBusyError
    from ..modelfit.crossval import CrossvalFolderError, crossvalidate
    from ..modelfit.fitting import FitError, FitFolderError
    from ..psychophysics.runner import FolderBusyError, OutputFolderError

    parser = args._parser
    check_backend_options(args, parser)
    out = prepare_out(args)

    def work() -> int:
        rows = crossvalidate(
            out,
            quick=args.quick,
            seed=args.seed,
            theories=args.theories,
            data_from=args.data_from,
            reports=args.reports,
            noise_deg=args.noise_deg,
            image_size=args.image_size,
            max_evals=args.max_evals,
            backend=args.backend,
            workers=args.workers,
            ray_address=args.ray_address,
            progress=not args.no_progress,
        )
        print((out / "summary.txt").read_text(), end="")
        print(f"wrote {out / 'crossval.csv'} ({len(rows)} rows), crossval_pairs.csv, crossval.png, summary.txt")
        return 0

    return guarded(
        "python -m experiments crossval",
        work,
        resume_hint=f"what was computed is kept in {out}: run the same command again to resume",
        usage=(CrossvalFolderError, FitFolderError, OutputFolderError),
        parser=parser,
        errors={FolderBusyError: 1, LockBusyError: 1, FitError: 1},
    )


def add_subcommand(subparsers) -> None:
    """Register ``crossval``."""
    from ..modelfit import crossval

    theories = crossval.THEORIES
    p = subparsers.add_parser(
        "crossval",
        help=HELP["crossval"],
        description=crossval.__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--out", type=out_dir, required=True, help="output folder (created; the same command resumes)")
    add_quick_option(
        p,
        "a small check: 4 flashes x 4 times, data from observer and paper, 64 px, 15 evaluations "
        "per fit (about a minute on 2 cores)",
    )
    add_seed_option(p, "seed of the motor noise, the report noise and the bootstrap")
    p.add_argument(
        "--theories",
        type=model_names,
        default=list(theories),
        metavar="A,B,...",
        help=f"theories fitted (default {','.join(theories)})",
    )
    p.add_argument(
        "--data-from",
        type=model_names,
        default=None,
        metavar="A,B,...",
        help="theories whose simulated observers give the data (default: --theories; with --quick observer,paper)",
    )
    add_reports_option(p, None, "default 2")
    add_noise_deg_option(p)
    add_image_size_option(p, "eye image side (32-1024; default 128, --quick 64)", metavar="PX")
    add_max_evals_option(p, None, "default 120, --quick 15")
    add_backend_options(p)
    add_workers_option(p, default=1, what="observing processes / Ray actors")
    add_no_progress_option(p, "no progress bars")
    p.set_defaults(func=run, _parser=p)
