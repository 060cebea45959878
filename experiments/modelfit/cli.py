"""``python -m experiments fit`` / ``compare`` / ``simulate``: the model-fitting commands.

    python -m experiments fit --data FILE --model NAME --out DIR [--backend local|ray] [--ray-address ADDR]
    python -m experiments compare --data FILE --models A,B,... --out DIR [same options]
    python -m experiments simulate --model NAME --params k=v,... --out FILE.csv [--reports N] [--seed S]

``fit`` writes ``DIR/fit.json`` (``model``, ``parameters``, ``se``, ``ci`` (95 %), ``log_likelihood``,
``aic``, ``bic``, ``n`` and more), ``fitted_trials.csv``, ``fit.png`` and ``fit_log.csv`` (every
evaluation; a second run resumes from the best). ``compare`` writes ``DIR/comparison.csv``
(``model, log_likelihood, aic, bic, n_parameters, n, delta_aic, delta_bic``, ranked by AIC),
``DIR/lrt.csv`` and each model's fit in ``DIR/<model>/``. Models: ``mechanistic``,
``mechanistic/no_command_remap``, ``mechanistic/no_references``, ``paper``
(``experiments.modelfit.likelihood``). The data format: ``experiments.modelfit.data``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from ..cli import int_in, out_dir

__all__ = ["add_subcommands"]

EXAMPLE = Path(__file__).resolve().parent.parent / "data" / "example_localization.csv"


def _models(text: str) -> list[str]:
    from .likelihood import FIT_MODELS

    names = [n.strip() for n in text.split(",") if n.strip()]
    bad = [n for n in names if n not in FIT_MODELS]
    if bad or not names:
        raise argparse.ArgumentTypeError(f"expected model names from {', '.join(FIT_MODELS)}; got {text!r}")
    return names


def _model(text: str) -> str:
    if "," in text:
        raise argparse.ArgumentTypeError(f"one model name; got {text!r} (compare fits several)")
    return _models(text)[0]


def _params(text: str) -> dict:
    out = {}
    for item in text.split(","):
        k, sep, v = item.partition("=")
        try:
            out[k.strip()] = float(v)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected name=value pairs separated by commas; got {item!r}") from None
        if not sep:
            raise argparse.ArgumentTypeError(f"expected name=value; got {item!r}")
    return out


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--data", type=Path, required=True, help=f"CSV or Parquet data file (bundled: {EXAMPLE.name})")
    p.add_argument("--out", type=out_dir, required=True, help="output folder (created; a fit there resumes)")
    p.add_argument("--backend", choices=("local", "ray"), default="local",
                   help="where trials are observed: local processes, or Ray (local instance, or --ray-address)")
    p.add_argument("--ray-address", default=None, metavar="ADDR",
                   help="a Ray cluster to join (e.g. ray://head:10001 or auto); default: start a local instance")
    p.add_argument("--workers", type=int_in(1, 256), default=2, help="processes / Ray actors, 1-256")
    p.add_argument("--max-evals", type=int_in(10, 100000), default=300,
                   help="likelihood evaluations of the optimizer per model, 10-100000")


def _load(args):
    from .data import DataFormatError, read_data

    try:
        return read_data(args.data)
    except DataFormatError as e:
        args._parser.error(f"argument --data: {e}")


def _fit(args) -> int:
    from .fitting import fit

    data = _load(args)
    r = fit(data, args.model, args.out, backend=args.backend, workers=args.workers, ray_address=args.ray_address,
            max_evals=args.max_evals)
    print(f"{r['model']}: log L = {r['log_likelihood']:.2f}, AIC {r['aic']:.2f}, BIC {r['bic']:.2f}, n = {r['n']}")
    for k, v in r["parameters"].items():
        lo, hi = r["ci"][k]
        print(f"  {k:16s} {v:10.4g}   95 % CI [{lo:.4g}, {hi:.4g}]")
    print(f"wrote {Path(args.out) / 'fit.json'}, fitted_trials.csv, fit.png")
    return 0


def _compare(args) -> int:
    from .fitting import compare

    data = _load(args)
    rows = compare(data, args.models, args.out, backend=args.backend, workers=args.workers,
                   ray_address=args.ray_address, max_evals=args.max_evals)
    print(f"{'model':32s} {'log L':>10s} {'AIC':>10s} {'BIC':>10s}  k  dAIC")
    for r in rows:
        print(f"{r['model']:32s} {r['log_likelihood']:10.2f} {r['aic']:10.2f} {r['bic']:10.2f} {r['n_parameters']:2d}"
              f"  {r['delta_aic']:.1f}")
    lrt = (Path(args.out) / "lrt.csv").read_text().strip().splitlines()
    for line in lrt[1:]:
        print("LRT " + line)
    print(f"wrote {Path(args.out) / 'comparison.csv'}, lrt.csv, comparison.png and each fit")
    return 0


def _simulate(args) -> int:
    from ..psychophysics import Design
    from .fitting import simulate_data
    from .likelihood import FIT_MODELS

    m = FIT_MODELS[args.model]
    values = {p.name: p.default for p in m.parameters}
    unknown = [k for k in args.params if k not in values]
    if unknown:
        args._parser.error(f"argument --params: {', '.join(unknown)} not a parameter of {args.model} "
                           f"({', '.join(values)})")
    for p in m.parameters:
        v = args.params.get(p.name, p.default)
        if not p.lo <= v <= p.hi:
            args._parser.error(f"argument --params: {p.name} must be in [{p.lo:g}, {p.hi:g}]; got {v:g}")
    values.update(args.params)
    offsets = ((-8.0, 3.0), (8.0, -3.0), (-4.0, -6.0), (4.0, 6.0), (-12.0, 3.0), (2.0, -4.0))
    design = Design(amplitudes_deg=tuple(args.amplitudes), flash_offsets_deg=offsets,
                    flash_times_ms=(-150, -100, -50, -25, 0, 25, 50, 100))
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    data = simulate_data(args.model, values, design, reports=args.reports, seed=args.seed, out_csv=out)
    meta = {"generated_by": "python -m experiments simulate", "model": args.model, "parameters": values,
            "amplitudes_deg": list(args.amplitudes), "flash_offsets_deg": [list(o) for o in offsets],
            "flash_times_ms": list(design.flash_times_ms), "conditions": ["references", "dark"],
            "reports_per_trial": args.reports, "seed": args.seed, "rows": len(data)}
    out.with_suffix(".json").write_text(json.dumps(meta, indent=2) + "\n")
    print(f"wrote {len(data)} rows to {out} (parameters in {out.with_suffix('.json')})")
    return 0


def add_subcommands(subparsers) -> None:
    """Register ``fit``, ``compare`` and ``simulate``."""
    p = subparsers.add_parser("fit", help="fit a perception model to localization data (maximum likelihood)",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    _common(p)
    p.add_argument("--model", type=_model, default="mechanistic", help="the model to fit")
    p.set_defaults(func=_fit, _parser=p)
    p = subparsers.add_parser("compare", help="fit several models to the same data and rank them (AIC, BIC, LRT)",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    _common(p)
    p.add_argument("--models", type=_models, default=["mechanistic", "mechanistic/no_command_remap", "paper"],
                   help="comma-separated model names")
    p.set_defaults(func=_compare, _parser=p)
    p = subparsers.add_parser("simulate", help="simulate a localization data set from a model (for recovery checks)",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--model", type=_model, default="mechanistic")
    p.add_argument("--params", type=_params, default={}, metavar="k=v,...", help="parameter values (others default)")
    p.add_argument("--amplitudes", type=lambda t: [float(x) for x in t.split(",")], default=[16.0, 24.0],
                   metavar="DEG,...", help="saccade amplitudes")
    p.add_argument("--reports", type=int_in(1, 100), default=3, help="noisy reports per trial, 1-100")
    p.add_argument("--seed", type=int_in(0, 2**31 - 1), default=0)
    p.add_argument("--out", type=Path, required=True, help="CSV file to write (and its .json beside it)")
    p.set_defaults(func=_simulate, _parser=p)
