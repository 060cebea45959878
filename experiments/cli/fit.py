"""``python -m experiments fit``: fit a perception model to localization data (``modelfit.fitting.fit``)."""

from __future__ import annotations

import argparse
from pathlib import Path

from .commands import HELP
from .fitting import DESCRIPTION, add_common_options, fit_options, model_name, prepare, run_guarded

__all__ = ["add_subcommand", "run"]


def add_subcommand(subparsers) -> None:
    """Register ``fit``."""
    p = subparsers.add_parser(
        "fit", help=HELP["fit"], description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    add_common_options(p)
    p.add_argument("--model", type=model_name, default="mechanistic", help="the model to fit")
    p.set_defaults(func=run, _parser=p)


def _ci_text(ci) -> str:
    lo, hi = ci
    return "not estimable" if lo is None or hi is None else f"[{lo:.4g}, {hi:.4g}]"


def run(args: argparse.Namespace) -> int:
    """``fit``: the maximum-likelihood fit into ``--out``; prints the estimates."""
    from ..modelfit.fitting import fit

    data, forward = prepare(args)

    def work() -> int:
        r = fit(
            data,
            args.model,
            args.out,
            **fit_options(args, forward),
        )
        if r["already_done"]:
            print(
                f"already finished: {Path(args.out) / 'fit.json'} holds this fit (fit_key {r['fit_key']}); "
                "nothing was recomputed"
            )
        print(f"{r['model']}: log L = {r['log_likelihood']:.2f}, AIC {r['aic']:.2f}, BIC {r['bic']:.2f}, n = {r['n']}")
        for k, v in r["parameters"].items():
            print(f"  {k:16s} {v:10.4g}   95 % CI {_ci_text(r['ci'][k])}")
        if r["at_bounds"]:
            print(f"  at a bound of its range: {', '.join(r['at_bounds'])}")
        print(f"wrote {Path(args.out) / 'fit.json'}, fitted_trials.csv, fit.png")
        return 0

    return run_guarded(args, work)
