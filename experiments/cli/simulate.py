"""``python -m experiments simulate``: a localization data set simulated from a model
(``modelfit.fitting.simulate_data``), e.g. for recovery checks."""

from __future__ import annotations

import argparse
from pathlib import Path

from .commands import HELP
from .fitting import DESCRIPTION, model_name, observing, run_guarded
from .options import (
    add_forward_model_options,
    add_no_progress_option,
    add_reports_option,
    add_seed_option,
    add_workers_option,
)
from .parsing import amplitude_list, out_file

__all__ = ["add_subcommand", "run"]


def add_subcommand(subparsers) -> None:
    """Register ``simulate``."""
    p = subparsers.add_parser(
        "simulate", help=HELP["simulate"], description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--model", type=model_name, default="mechanistic")
    p.add_argument("--params", type=_params, default={}, metavar="k=v,...", help="parameter values (others default)")
    p.add_argument(
        "--amplitudes",
        type=amplitude_list,
        default=(16.0, 24.0),
        metavar="DEG,...",
        help="saccade amplitudes (deg), each once",
    )
    add_reports_option(p, 3)
    add_seed_option(p, "seed of the trials and the report noise")
    add_workers_option(p, default=1, what="processes observing the trials")
    add_no_progress_option(p, "no progress bar")
    p.add_argument(
        "--out",
        type=out_file(".csv"),
        required=True,
        help="CSV file to write (a .json of the same name beside it holds the parameters and the "
        "configuration that fit reads)",
    )
    add_forward_model_options(p, "TrialConfig's, at 128 px")
    p.set_defaults(func=run, _parser=p, image_size=128)


def _params(text: str) -> dict:
    import math

    out = {}
    for item in text.split(","):
        k, sep, v = item.partition("=")
        if not sep:
            raise argparse.ArgumentTypeError(f"expected name=value; got {item!r}")
        try:
            value = float(v)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected name=value pairs separated by commas; got {item!r}") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"{k.strip()} must be a finite number; got {v!r}")
        if k.strip() in out:
            raise argparse.ArgumentTypeError(f"{k.strip()} is given twice in {text!r}")
        out[k.strip()] = value
    return out


def run(args: argparse.Namespace) -> int:
    """``simulate``: the data set into ``--out`` (CSV, with its JSON sidecar)."""
    from ..folders import path_lock
    from ..modelfit.fitting import simulate_data
    from ..modelfit.likelihood import FIT_MODELS
    from ..psychophysics import Design, TrialConfig

    parser = args._parser
    m = FIT_MODELS[args.model]
    values = {p.name: p.default for p in m.parameters}
    unknown = [k for k in args.params if k not in values]
    if unknown:
        parser.error(f"argument --params: {', '.join(unknown)} not a parameter of {args.model} ({', '.join(values)})")
    for p in m.parameters:
        v = args.params.get(p.name, p.default)
        if not p.lo <= v <= p.hi:
            parser.error(f"argument --params: {p.name} must be in [{p.lo:g}, {p.hi:g}]; got {v:g}")
    values.update(args.params)
    offsets = ((-8.0, 3.0), (8.0, -3.0), (-4.0, -6.0), (4.0, 6.0), (-12.0, 3.0), (2.0, -4.0))
    try:
        design = Design(
            amplitudes_deg=tuple(args.amplitudes),
            flash_offsets_deg=offsets,
            flash_times_ms=(-150, -100, -50, -25, 0, 25, 50, 100),
            seed=args.seed,
        )
        config = TrialConfig(**{k: v for k, v in observing(args).items() if v is not None})
    except (TypeError, ValueError) as e:
        parser.error(str(e))
    out: Path = args.out
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        parser.error(f"argument --out: cannot create {out.parent}: {e.strerror or e}")

    def work() -> int:
        with path_lock(out.parent / f".{out.name}.lock", str(out)):
            data = simulate_data(
                args.model,
                values,
                design,
                reports=args.reports,
                seed=args.seed,
                out_csv=out,
                workers=args.workers,
                config=config,
                progress=not args.no_progress,
            )
        print(f"wrote {len(data)} rows to {out} (parameters and configuration in {out.with_suffix('.json')})")
        return 0

    return run_guarded(args, work)
