"""``python -m experiments recovery``: model recovery (``experiments.modelfit.recovery``, whose
docstring is the command's description)."""

from __future__ import annotations

import argparse

from .commands import HELP
from .options import (
    add_backend_options,
    add_image_size_option,
    add_max_evals_option,
    add_no_progress_option,
    add_noise_deg_option,
    add_reports_option,
    add_workers_option,
    check_backend_options,
    prepare_out,
)
from .parsing import guarded, out_dir

__all__ = ["add_subcommand", "run"]


def add_subcommand(subparsers) -> None:
    """Register ``recovery``."""
    from ..modelfit import recovery

    p = subparsers.add_parser(
        "recovery",
        help=HELP["recovery"],
        description=recovery.__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--out", type=out_dir, default="results/recovery", help="output folder (created; resumed)")
    p.add_argument(
        "--size",
        choices=("default", "small"),
        default="default",
        help="default: 8 flashes x 8 times x 2 conditions x --reports reports (256 rows at 2); small: "
        "4 x 3 x 2 (a quick check)",
    )
    add_reports_option(p, 2, "default 2")
    add_noise_deg_option(p)
    add_image_size_option(p, "eye image side (32-1024)", default=128, metavar="PX")
    add_max_evals_option(p, 120, "default 120")
    add_workers_option(p, default=1, what="processes / Ray actors observing the trials")
    add_backend_options(p)
    add_no_progress_option(p, "no progress bars")
    p.set_defaults(func=run, _parser=p)


def run(args: argparse.Namespace) -> int:
    """``recovery``: :func:`experiments.modelfit.recovery.recover` into ``--out``; prints who won."""
    from ..folders import path_lock
    from ..modelfit.recovery import GENERATING, recover
    from ..psychophysics.runner import FolderBusyError

    check_backend_options(args, args._parser)
    out = prepare_out(args)

    def work() -> int:
        with path_lock(out / ".recovery.lock"):
            rows = recover(
                out,
                size=args.size,
                reports=args.reports,
                noise_deg=args.noise_deg,
                image_size=args.image_size,
                max_evals=args.max_evals,
                workers=args.workers,
                progress=not args.no_progress,
                backend=args.backend,
                ray_address=args.ray_address,
            )
        for gen in GENERATING:
            mine = [r for r in rows if r["generating"] == gen]
            order = ", ".join(f"{r['fitted']} {r['delta_aic']:+.1f}" for r in sorted(mine, key=lambda r: r["aic"]))
            print(f"data from {gen:10s}: {order}  ({'recovered' if mine[0]['recovered'] else 'NOT recovered'})")
        print(f"wrote {out / 'recovery.csv'} and {out / 'recovery.png'}")
        return 0

    from ..folders import LockBusyError

    return guarded(
        "python -m experiments recovery",
        work,
        resume_hint=f"finished data sets and fits are kept in {out}: run the same command again to resume",
        errors={FolderBusyError: 1, LockBusyError: 1, ValueError: 2},
    )
