"""``python -m experiments fit`` / ``compare`` / ``simulate``: the model-fitting commands.

    python -m experiments fit --data FILE --model NAME --out DIR [--backend local|ray] [--ray-address ADDR]
    python -m experiments compare --data FILE --models A,B,... --out DIR [same options]
    python -m experiments simulate --model NAME --params k=v,... --out FILE.csv [--reports N] [--seed S]

``fit`` writes ``DIR/fit.json`` (``model``, ``parameters``, ``se``, ``ci`` (95 %), ``log_likelihood``,
``aic``, ``bic``, ``n``, ``fit_key``, ``forward_model`` and more; strict JSON, ``null`` where an
interval does not exist), ``fitted_trials.csv``, ``fit.png``, ``fit_log.csv`` (every evaluation,
checksummed) and ``observations/`` (the rendered trials, ``.npz`` without pickle). The same command
again resumes an interrupted fit to the same result, or says that the fit is finished. ``compare``
writes ``DIR/comparison.csv`` (``model, log_likelihood, aic, bic, n_parameters, n, delta_aic,
delta_bic``, ranked by AIC), ``DIR/lrt.csv`` and each model's fit in ``DIR/<model>/``. Models:
``mechanistic``, ``mechanistic/no_command_remap``, ``mechanistic/no_references``, ``paper``
(``experiments.modelfit.likelihood``). The data format: ``experiments.modelfit.data``; the forward
model (image size, field of view, ...) comes from the data's sidecar (``run.json`` of a run, the
``.json`` of a simulation) or the options below (``experiments.modelfit.forward``).

Exit status: 0 done (or already done); 1 the model cannot be fitted (rows named), the folder is in
use by another process, or an I/O error; 2 a usage error (bad option, data file or folder); 130 /
143 interrupted (what was computed is kept: run the same command again to resume).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..cli import GENERATOR_HELP, amplitude_list, bounded, generator_file, guarded, int_in, out_dir, out_file
from ..cli.options import add_backend_options, add_workers_option, check_backend_options, seed_type

__all__ = ["add_subcommands", "bundled_data"]

DATA_DIR = Path(__file__).resolve().parent.parent / "data"
EXAMPLE = DATA_DIR / "example_localization.csv"


def bundled_data(text: str) -> Path:
    """``--data``: a file path; a bare name that is not a file here but is one of the bundled data
    sets (``experiments/data``, installed with the package) resolves to that."""
    p = Path(text)
    if not p.exists() and p.parent == Path(".") and (DATA_DIR / p.name).is_file():
        return DATA_DIR / p.name
    return p


def _models(text: str) -> list[str]:
    from .likelihood import FIT_MODELS

    names = [n.strip() for n in text.split(",") if n.strip()]
    bad = [n for n in names if n not in FIT_MODELS]
    if bad or not names:
        raise argparse.ArgumentTypeError(f"expected model names from {', '.join(FIT_MODELS)}; got {text!r}")
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise argparse.ArgumentTypeError(f"model {dup[0]} is listed twice in {text!r}; list each once")
    return names


def _model(text: str) -> str:
    if "," in text:
        raise argparse.ArgumentTypeError(f"one model name; got {text!r} (compare fits several)")
    return _models(text)[0]


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


def _observing_options(p: argparse.ArgumentParser, defaults_from: str) -> None:
    g = p.add_argument_group(f"forward model (default: {defaults_from})")
    g.add_argument("--image-size", type=bounded("image_size"), default=None, help="eye image side (px)")
    g.add_argument("--fovy-deg", type=bounded("fovy_deg"), default=None, help="each eye's vertical field of view")
    g.add_argument("--fovea-deg", type=bounded("fovea_deg"), default=None, help="foveal radius of the retina")
    g.add_argument("--saccade-model", choices=("burst", "legacy"), default=None, help="saccade trajectories")
    g.add_argument("--generator", type=generator_file, default=None, metavar="FILE", help=GENERATOR_HELP)
    g.add_argument(
        "--endpoint-noise",
        type=bounded("endpoint_noise"),
        default=None,
        help="saccade endpoint noise (fraction of the amplitude; trials' seeds from the data)",
    )


def _observing(args) -> dict:
    from .forward import OBSERVING_OPTIONS

    return {k: getattr(args, k) for k in OBSERVING_OPTIONS}


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--data",
        type=bundled_data,
        required=True,
        help=f"CSV or Parquet data file (bundled: {EXAMPLE.name}, found by that name)",
    )
    p.add_argument("--out", type=out_dir, required=True, help="output folder (created; the same fit there resumes)")
    add_backend_options(p)
    add_workers_option(p)
    p.add_argument(
        "--max-evals",
        type=int_in(10, 100000),
        default=300,
        help="likelihood evaluations of the optimizer per model, 10-100000",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    _observing_options(p, "the data's sidecar, else run's defaults")


def _prepare(args):
    """Checks that need more than one option, the data, its forward model and the folder: usage
    errors, before work. Returns the data and its forward model."""
    from ..psychophysics.runner import OutputFolderError, prepare_output_folder
    from .data import DataFormatError, read_data
    from .forward import ForwardModelError, forward_model

    parser = args._parser
    check_backend_options(args, parser)
    try:
        data = read_data(args.data)
    except DataFormatError as e:
        parser.error(f"argument --data: {e}")
    try:
        forward = forward_model(data, _observing(args))
    except ForwardModelError as e:
        parser.error(f"argument --data: {e}")
    try:
        prepare_output_folder(args.out)
    except (OutputFolderError, TypeError) as e:
        parser.error(f"argument --out: {e}")
    return data, forward


def _guarded(args, work) -> int:
    """Run ``work()`` with SIGINT/SIGTERM as interruptions; one-line errors, never a traceback."""
    from ..folders import LockBusyError
    from ..psychophysics.runner import FolderBusyError, OutputFolderError
    from .fitting import FitError, FitFolderError

    return guarded(
        f"python -m experiments {args.command}",
        work,
        resume_hint=f"what was computed is kept in {args.out}: run the same command again to resume",
        usage=(FitFolderError, OutputFolderError),
        parser=args._parser,
        errors={FolderBusyError: 1, LockBusyError: 1, FitError: 1},
    )


def _ci_text(ci) -> str:
    lo, hi = ci
    return "not estimable" if lo is None or hi is None else f"[{lo:.4g}, {hi:.4g}]"


def _fit(args) -> int:
    from .fitting import fit

    data, forward = _prepare(args)

    def work() -> int:
        r = fit(
            data,
            args.model,
            args.out,
            backend=args.backend,
            workers=args.workers,
            ray_address=args.ray_address,
            max_evals=args.max_evals,
            forward=forward,
            progress=not args.no_progress,
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

    return _guarded(args, work)


def _compare(args) -> int:
    from .fitting import compare

    data, forward = _prepare(args)

    def work() -> int:
        rows = compare(
            data,
            args.models,
            args.out,
            backend=args.backend,
            workers=args.workers,
            ray_address=args.ray_address,
            max_evals=args.max_evals,
            forward=forward,
            progress=not args.no_progress,
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

    return _guarded(args, work)


def _simulate(args) -> int:
    from ..folders import path_lock
    from ..psychophysics import Design, TrialConfig
    from .fitting import simulate_data
    from .likelihood import FIT_MODELS

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
        config = TrialConfig(**{k: v for k, v in _observing(args).items() if v is not None})
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

    return _guarded(args, work)


def add_subcommands(subparsers) -> None:
    """Register ``fit``, ``compare`` and ``simulate``."""
    p = subparsers.add_parser(
        "fit",
        help="fit a perception model to localization data (maximum likelihood)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _common(p)
    p.add_argument("--model", type=_model, default="mechanistic", help="the model to fit")
    p.set_defaults(func=_fit, _parser=p)
    p = subparsers.add_parser(
        "compare",
        help="fit several models to the same data and rank them (AIC, BIC, LRT)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _common(p)
    p.add_argument(
        "--models",
        type=_models,
        default=["mechanistic", "mechanistic/no_command_remap", "paper"],
        help="comma-separated model names, each once",
    )
    p.set_defaults(func=_compare, _parser=p)
    p = subparsers.add_parser(
        "simulate",
        help="simulate a localization data set from a model (for recovery checks)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--model", type=_model, default="mechanistic")
    p.add_argument("--params", type=_params, default={}, metavar="k=v,...", help="parameter values (others default)")
    p.add_argument(
        "--amplitudes",
        type=amplitude_list,
        default=(16.0, 24.0),
        metavar="DEG,...",
        help="saccade amplitudes (deg), each once",
    )
    p.add_argument("--reports", type=int_in(1, 100), default=3, help="noisy reports per trial, 1-100")
    p.add_argument("--seed", type=seed_type(), default=0, help="seed of the trials and the report noise")
    add_workers_option(p, default=1, what="processes observing the trials")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument(
        "--out",
        type=out_file(".csv"),
        required=True,
        help="CSV file to write (a .json of the same name beside it holds the parameters and the "
        "configuration that fit reads)",
    )
    _observing_options(p, "TrialConfig's, at 128 px")
    p.set_defaults(func=_simulate, _parser=p, image_size=128)
