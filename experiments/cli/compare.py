"""``python -m experiments compare``: fit several models to the same data and rank them
(``modelfit.fitting.compare``)."""

from __future__ import annotations

import argparse
from pathlib import Path

from .commands import HELP
from .fitting import DESCRIPTION, add_common_options, fit_options, model_names, prepare, run_guarded

__all__ = ["add_subcommand", "run"]


def add_subcommand(subparsers) -> None:
    """Register ``compare``."""
    p = subparsers.add_parser(
        "compare", help=HELP["compare"], description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    add_common_options(p)
    p.add_argument(
        "--models",
        type=model_names,
        default=["mechanistic", "mechanistic/no_command_remap", "paper"],
        help="comma-separated model names, each once",
    )
    p.set_defaults(func=run, _parser=p)


def run(args: argparse.Namespace) -> int:
    """``compare``: every model fitted into ``--out``, ranked; prints the table and the LRTs."""
    from ..modelfit.fitting import compare

    data, forward = prepare(args)

    def work() -> int:
        rows = compare(
            data,
            args.models,
            args.out,
            **fit_options(args, forward),
        )
        print(f"{'model':32s} {'log L':>10s} {'AIC':>10s} {'BIC':>10s}  k  dAIC")
        for r in rows:
            print(
                f"{r['model']:32s} {r['log_likelihood']:10.2f} {r['aic']:10.2f} {r['bic']:10.2f} "
                f"{r['n_parameters']:2d}  {r['delta_aic']:.1f}"
            )
        lrt = (Path(args.out) / "lrt.csv").read_text().strip().splitlines()
        for line in lrt[1:]:
            print("LRT " + line)
        print(f"wrote {Path(args.out) / 'comparison.csv'}, lrt.csv, comparison.png and each fit")
        return 0

    return run_guarded(args, work)
