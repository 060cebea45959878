"""The options several commands share, each declared once here with one range and one help text.

``--seed`` and ``--image-size`` are bounded by ``psychophysics.bounds.LIMITS`` (the ranges ``run``
checks); ``--task`` chooses from :data:`TASKS` (the agents' tasks; ``visualize`` adds ``free``).
``--workers`` is bounded by ``psychophysics.bounds.LIMITS["workers"]``; ``--backend local|ray`` and
``--ray-address`` say where the heavy commands (``run``, ``phenomena``, ``fit``, ``compare``,
``recovery``) run their trials and ``baselines`` its training runs (``psychophysics.backends``). :func:`check_backend_options` turns a
bad combination into a usage error before any work.
"""

from __future__ import annotations

import argparse

from .parsing import bounded

__all__ = [
    "ENV_TASKS",
    "TASKS",
    "add_backend_options",
    "add_workers_option",
    "check_backend_options",
    "image_size_type",
    "seed_type",
]

#: The tasks an agent is trained and evaluated on (``envs.tasks.TASKS`` without free viewing).
TASKS = ("fixate", "search")
#: Every task of the env (``envs.tasks.TASKS``).
ENV_TASKS = ("fixate", "search", "free")


def seed_type():
    """The argparse type of every ``--seed``: a whole number in ``LIMITS["seed"]`` (0 to 2^31 - 1)."""
    return bounded("seed")


def image_size_type():
    """The argparse type of every ``--image-size``: a whole number in ``LIMITS["image_size"]`` (px)."""
    return bounded("image_size")


def add_workers_option(p, default: int = 2, what: str = "processes / Ray actors") -> None:
    """``--workers N`` (1-64): ``what`` runs the trials; 1 = in this process with the local backend."""
    p.add_argument(
        "--workers",
        type=bounded("workers"),
        default=default,
        metavar="N",
        help=f"{what}, 1-64 (default {default}); 1 = in-process with --backend local",
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
