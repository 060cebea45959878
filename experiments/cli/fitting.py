"""What ``fit``, ``compare`` and ``simulate`` share: their description, their model names, their
options and the checks and error handling around the work (``experiments.modelfit``)."""

from __future__ import annotations

import argparse

from .options import (
    add_backend_options,
    add_data_option,
    add_forward_model_options,
    add_max_evals_option,
    add_no_progress_option,
    add_workers_option,
    check_backend_options,
    digits_in,
    prepare_out,
)
from .parsing import guarded, out_dir

__all__ = [
    "DESCRIPTION",
    "add_common_options",
    "fit_options",
    "model_name",
    "model_names",
    "observing",
    "prepare",
    "run_guarded",
]

#: The description of ``fit``, ``compare`` and ``simulate`` (their ``--help``).
DESCRIPTION = """``python -m experiments fit`` / ``compare`` / ``simulate``: the model-fitting commands.

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


def model_names(text: str) -> list[str]:
    """``--models``: comma-separated names of ``modelfit.likelihood.FIT_MODELS``, each once."""
    from ..modelfit.likelihood import FIT_MODELS

    names = [n.strip() for n in text.split(",") if n.strip()]
    bad = [n for n in names if n not in FIT_MODELS]
    if bad or not names:
        raise argparse.ArgumentTypeError(f"expected model names from {', '.join(FIT_MODELS)}; got {text!r}")
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise argparse.ArgumentTypeError(f"model {dup[0]} is listed twice in {text!r}; list each once")
    return names


def model_name(text: str) -> str:
    """``--model``: one name of ``modelfit.likelihood.FIT_MODELS``."""
    if "," in text:
        raise argparse.ArgumentTypeError(f"one model name; got {text!r} (compare fits several)")
    return model_names(text)[0]


def observing(args) -> dict:
    """The forward-model options (``modelfit.forward.OBSERVING_OPTIONS``) as given (None: not given)."""
    from ..modelfit.forward import OBSERVING_OPTIONS

    return {k: getattr(args, k) for k in OBSERVING_OPTIONS}


def add_common_options(p: argparse.ArgumentParser) -> None:
    """The options of ``fit`` and ``compare``."""
    add_data_option(p)
    p.add_argument("--out", type=out_dir, required=True, help="output folder (created; the same fit there resumes)")
    add_backend_options(p)
    add_workers_option(p)
    add_max_evals_option(p, 300)
    add_no_progress_option(p, "no progress bars")
    add_forward_model_options(p, "the data's sidecar, else run's defaults")
    from ..modelfit.forward import MAX_MOTOR_DRAWS

    p.add_argument(
        "--motor-draws",
        type=digits_in(0, MAX_MOTOR_DRAWS),
        default=0,
        metavar="K",
        help=f"with motor noise (--endpoint-noise > 0): observe each trial with K landing errors of its own "
        f"(2-{MAX_MOTOR_DRAWS}) and fit their mean, their variance added to the report noise's -- the motor "
        "noise marginalised, as a person's data need; 0 (default): replay each row's seed (a simulation's "
        "own landing errors)",
    )


def prepare(args):
    """Checks that need more than one option, the data, its forward model and the folder: usage
    errors, before work. Returns the data and its forward model."""
    from ..modelfit.data import DataFormatError, read_data
    from ..modelfit.forward import ForwardModelError, forward_model

    parser = args._parser
    check_backend_options(args, parser)
    try:
        data = read_data(args.data)
    except DataFormatError as e:
        parser.error(f"argument --data: {e}")
    try:
        forward = forward_model(data, observing(args), motor_draws=args.motor_draws)
    except ForwardModelError as e:
        parser.error(f"argument --data: {e}")
    prepare_out(args)
    return data, forward


def fit_options(args, forward) -> dict:
    """The keyword arguments ``modelfit.fitting.fit`` and ``compare`` take from the shared options."""
    return {
        "backend": args.backend,
        "workers": args.workers,
        "ray_address": args.ray_address,
        "max_evals": args.max_evals,
        "forward": forward,
        "progress": not args.no_progress,
    }


def run_guarded(args, work) -> int:
    """Run ``work()`` with SIGINT/SIGTERM as interruptions; one-line errors, never a traceback."""
    from ..folders import LockBusyError
    from ..modelfit.fitting import FitError, FitFolderError
    from ..psychophysics.runner import FolderBusyError, OutputFolderError

    return guarded(
        f"python -m experiments {args.command}",
        work,
        resume_hint=f"what was computed is kept in {args.out}: run the same command again to resume",
        usage=(FitFolderError, OutputFolderError),
        parser=args._parser,
        errors={FolderBusyError: 1, LockBusyError: 1, FitError: 1},
    )
