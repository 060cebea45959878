"""The options several commands share, each declared once here with one range and one help text.

``--seed`` and ``--image-size`` are bounded by ``psychophysics.bounds.LIMITS`` (the ranges ``run``
checks); ``--task`` chooses from :data:`TASKS` (the agents' tasks; ``visualize`` adds ``free``).
``--workers`` is bounded by ``psychophysics.bounds.LIMITS["workers"]``; ``--backend local|ray`` and
``--ray-address`` say where the heavy commands (``run``, ``phenomena``, ``fit``, ``compare``,
``recovery``, ``crossval``) run their trials and ``baselines`` its training runs
(``psychophysics.backends``). :func:`check_backend_options` turns a bad combination into a usage
error before any work. The fitting commands share ``--data``, ``--max-evals``, ``--reports``,
``--noise-deg`` and the forward-model options; their ranges are in ``LIMITS`` too. ``SHARED`` names every option declared here: no command declares one itself.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path

from ..psychophysics.bounds import LIMITS
from .parsing import GENERATOR_HELP, bounded, generator_file

__all__ = [
    "ENV_TASKS",
    "SERVER_BOUNDS",
    "SHARED",
    "TASKS",
    "add_backend_options",
    "add_data_option",
    "add_forward_model_options",
    "add_generator_option",
    "add_image_size_option",
    "add_max_evals_option",
    "add_no_progress_option",
    "add_noise_deg_option",
    "add_quick_option",
    "add_reports_option",
    "add_seed_option",
    "add_server_options",
    "add_task_option",
    "add_timesteps_option",
    "add_workers_option",
    "bundled_data",
    "check_backend_options",
    "digits_in",
    "image_size_type",
    "prepare_out",
    "seed_type",
]

#: The tasks an agent is trained and evaluated on (``envs.tasks.TASKS`` without free viewing).
TASKS = ("fixate", "search")
#: Every task of the env (``envs.tasks.TASKS``).
ENV_TASKS = ("fixate", "search", "free")

#: Every option declared here (a test checks that no command declares one of them itself).
SHARED = (
    "--seed",
    "--image-size",
    "--workers",
    "--backend",
    "--ray-address",
    "--task",
    "--quick",
    "--no-progress",
    "--generator",
    "--data",
    "--max-evals",
    "--reports",
    "--noise-deg",
    "--timesteps",
    "--serve-seconds",
    "--web-port",
    "--grpc-port",
)

#: The bundled data sets (``experiments/data``, installed with the package).
DATA_DIR = Path(__file__).resolve().parent.parent / "data"
EXAMPLE = DATA_DIR / "example_localization.csv"


def seed_type() -> Callable[[str], float | int]:
    """The argparse type of every ``--seed``: a whole number in ``LIMITS["seed"]`` (0 to 2^31 - 1)."""
    return bounded("seed")


def image_size_type() -> Callable[[str], float | int]:
    """The argparse type of every ``--image-size``: a whole number in ``LIMITS["image_size"]`` (px)."""
    return bounded("image_size")


def add_seed_option(p, help: str, default: int | None = 0, **kw) -> None:
    """``--seed S``, a whole number in ``LIMITS["seed"]``."""
    p.add_argument("--seed", type=seed_type(), default=default, help=help, **kw)


def add_image_size_option(p, help: str, default: int | None = None, **kw) -> None:
    """``--image-size PX``, a whole number in ``LIMITS["image_size"]``."""
    p.add_argument("--image-size", type=image_size_type(), default=default, help=help, **kw)


def add_task_option(p, tasks: tuple[str, ...] = TASKS, default: str = "fixate") -> None:
    """``--task``: one of ``tasks`` (:data:`TASKS`, or :data:`ENV_TASKS` with free viewing)."""
    p.add_argument("--task", choices=tasks, default=default, help=f"env task (default: {default})")


def add_quick_option(p, help: str) -> None:
    """``--quick``: the command's small version (``help`` says what it is)."""
    p.add_argument("--quick", action="store_true", help=help)


def add_no_progress_option(p, help: str = "no progress bars (they go to stderr)") -> None:
    """``--no-progress``."""
    p.add_argument("--no-progress", action="store_true", help=help)


def add_generator_option(p) -> None:
    """``--generator FILE``: burst-generator parameters (``parsing.generator_file``)."""
    p.add_argument("--generator", type=generator_file, default=None, metavar="FILE", help=GENERATOR_HELP)


#: ``--workers``' default where it is None (``run``): ``psychophysics.runner.SMALL_RUN_TRIALS`` (a test
#: checks the number; the module is not imported here, to keep ``--help`` fast).
AUTO_WORKERS_HELP = "2, or 1 when at most 64 trials are left to do: a worker takes longer to start"


def add_workers_option(p, default: int | None = 2, what: str = "processes / Ray actors") -> None:
    """``--workers N`` (1-64): ``what`` runs the trials; 1 = in this process with the local backend;
    ``default`` None: ``AUTO_WORKERS_HELP``."""
    shown = AUTO_WORKERS_HELP if default is None else default
    p.add_argument(
        "--workers",
        type=bounded("workers"),
        default=default,
        metavar="N",
        help=f"{what}, 1-64 (default {shown}); 1 = in-process with --backend local",
    )


def add_backend_options(p, what: str = "where trials are observed") -> None:
    """``--backend local|ray`` and ``--ray-address ADDR``."""
    p.add_argument(
        "--backend",
        choices=("local", "ray"),
        default="local",
        help=f"{what}: local processes, or Ray (local instance, or --ray-address)",
    )
    p.add_argument(
        "--ray-address",
        default=None,
        metavar="ADDR",
        help="with --backend ray: a Ray cluster to join (e.g. ray://head:10001 or auto); default: "
        "start a local instance",
    )


def check_backend_options(args: argparse.Namespace, parser: argparse.ArgumentParser) -> None:
    """Usage errors: ``--ray-address`` without ``--backend ray``, or ``--backend ray`` without Ray."""
    if args.ray_address is not None and args.backend != "ray":
        parser.error("argument --ray-address: only with --backend ray (the local backend starts no cluster)")
    if args.backend == "ray":
        try:
            import ray  # noqa: F401  (imported only to check that it is installed)
        except ImportError:
            parser.error('argument --backend: ray is not installed: pip install -e ".[ray]"')


def prepare_out(args: argparse.Namespace) -> Path:
    """The ``--out`` folder of a command that writes a results folder, created and checked writable
    (``psychophysics.runner.prepare_output_folder``): a usage error naming ``--out`` where it cannot be."""
    from ..psychophysics.runner import OutputFolderError, prepare_output_folder

    parser: argparse.ArgumentParser = args._parser
    try:
        return prepare_output_folder(args.out)
    except (OutputFolderError, TypeError) as e:
        parser.error(f"argument --out: {e}")


def _range(name: str) -> str:
    lim = LIMITS[name]
    return f"{lim.lo:g}-{lim.hi:g}"


def add_max_evals_option(p, default: int | None, help: str = "") -> None:
    """``--max-evals N``: likelihood evaluations of the optimizer per fit, in ``LIMITS["max_evals"]``."""
    p.add_argument(
        "--max-evals",
        type=bounded("max_evals"),
        default=default,
        metavar="N",
        help=f"likelihood evaluations of the optimizer per fit, {_range('max_evals')}" + (f" ({help})" if help else ""),
    )


def add_reports_option(p, default: int | None, help: str = "") -> None:
    """``--reports N``: noisy reports per simulated trial, in ``LIMITS["reports"]``."""
    p.add_argument(
        "--reports",
        type=bounded("reports"),
        default=default,
        metavar="N",
        help=f"noisy reports per trial, {_range('reports')}" + (f" ({help})" if help else ""),
    )


def add_noise_deg_option(p, default: float = 1.5) -> None:
    """``--noise-deg DEG``: the report noise s.d. of the simulated observers, in ``LIMITS["noise_deg"]``."""
    p.add_argument(
        "--noise-deg",
        type=bounded("noise_deg"),
        default=default,
        metavar="DEG",
        help=f"report noise s.d. of the simulated observers (deg, {_range('noise_deg')}; default {default:g})",
    )


def add_timesteps_option(p, help: str, default: int | None = None) -> None:
    """``--timesteps N``: the steps of a PPO/SAC run, in ``LIMITS["timesteps"]``."""
    p.add_argument("--timesteps", type=bounded("timesteps"), default=default, help=help)


def bundled_data(text: str) -> Path:
    """``--data``: a file path; a bare name that is not a file here but is one of the bundled data
    sets (``experiments/data``, installed with the package) resolves to that."""
    p = Path(text)
    if not p.exists() and p.parent == Path(".") and (DATA_DIR / p.name).is_file():
        return DATA_DIR / p.name
    return p


def add_data_option(p) -> None:
    """``--data FILE``: a localization data set (:func:`bundled_data`)."""
    p.add_argument(
        "--data",
        type=bundled_data,
        required=True,
        help=f"CSV or Parquet data file (bundled: {EXAMPLE.name}, found by that name)",
    )


def add_forward_model_options(p, defaults_from: str) -> None:
    """The forward model's options of ``fit``, ``compare`` and ``simulate`` (``modelfit.forward``):
    ``TrialConfig``'s fields ``image_size``, ``fovy_deg``, ``fovea_deg``, ``saccade_model``,
    ``endpoint_noise`` (ranges from ``LIMITS``, choices from ``trial_fields``) and ``--generator``;
    default None: from ``defaults_from``."""
    from .trialconfig import add_trial_options

    g = p.add_argument_group(f"forward model (default: {defaults_from})")
    add_trial_options(
        g,
        {
            "image_size": "eye image side",
            "fovy_deg": "each eye's vertical field of view",
            "fovea_deg": "foveal radius of the retina",
            "saccade_model": "saccade trajectories",
        },
        defaults=False,
    )
    add_generator_option(g)
    add_trial_options(
        g,
        {"endpoint_noise": "saccade endpoint noise (fraction of the amplitude; trials' seeds from the data)"},
        defaults=False,
    )


def digits_in(lo: int, hi: int) -> Callable[[str], int]:
    """argparse type: a whole number (decimal digits, no exponent or fraction) in ``lo..hi``."""

    def parse(text: str) -> int:
        try:
            v = int(str(text).strip(), 10)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number in {lo}..{hi}; got {text!r}") from None
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"expected a whole number in {lo}..{hi}; got {text!r}")
        return v

    parse.__name__ = "whole number"
    return parse


#: Bounds (inclusive) of the Rerun server's options of ``visualize --serve`` and ``view``.
SERVER_BOUNDS = {"serve_seconds": (1, 7 * 24 * 3600), "web_port": (0, 65535), "grpc_port": (0, 65535)}


def add_server_options(p, prefix: str, seconds_help: str) -> None:
    """``--serve-seconds``, ``--web-port``, ``--grpc-port`` of the Rerun web viewer (``prefix``: e.g.
    ``"with --serve: "``)."""
    b = SERVER_BOUNDS
    p.add_argument("--serve-seconds", type=digits_in(*b["serve_seconds"]), default=None, metavar="S", help=seconds_help)
    p.add_argument(
        "--web-port",
        type=digits_in(*b["web_port"]),
        default=9090,
        help=f"{prefix}port of the web viewer on 127.0.0.1 (default 9090; 0: a free one, printed)",
    )
    p.add_argument(
        "--grpc-port",
        type=digits_in(*b["grpc_port"]),
        default=9876,
        help=f"{prefix}port of the gRPC proxy the viewer reads from, on 127.0.0.1 (default 9876; 0: a free one)",
    )
