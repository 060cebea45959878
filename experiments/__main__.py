"""``python -m experiments COMMAND``: the project's commands.

``COMMANDS`` names each command, the module that defines it and its one-line help. Only the chosen
command's module is imported (it builds its subparser with ``add_subcommand(subparsers)`` or
``add_subcommands``, setting ``func`` to the function that runs it); the others are listed by
name and help. So ``--help``, a mistyped command and a usage error answer without importing
numba, MuJoCo, torch or Rerun. ``build_parser()`` builds every command's subparser (for tests and
documentation).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys

from .cli import HintingParser

#: command -> (module that registers it, one-line help), in the order ``--help`` lists them. A
#: module that registers several commands lists them here consecutively, in its own order.
COMMANDS: dict[str, tuple[str, str]] = {
    "run": (
        "experiments.psychophysics.study.cli",
        "perisaccadic flash-localization study (table, figures, summary, Rerun recording)",
    ),
    "saccades": (
        "experiments.oculomotor.saccades",
        "saccade kinematics vs the published main sequence (figure, table)",
    ),
    "phenomena": (
        "experiments.psychophysics.phenomena",
        "which published perisaccadic phenomena each theory predicts (table with CIs, calibrated/predicted, figures)",
    ),
    "fit": ("experiments.modelfit.cli", "fit a perception model to localization data (maximum likelihood)"),
    "compare": ("experiments.modelfit.cli", "fit several models to the same data and rank them (AIC, BIC, LRT)"),
    "simulate": ("experiments.modelfit.cli", "simulate a localization data set from a model (for recovery checks)"),
    "recovery": (
        "experiments.modelfit.recovery",
        "model recovery: simulate from each theory, fit every theory, confusion matrix of delta AIC",
    ),
    "crossval": (
        "experiments.modelfit.crossval",
        "cross-validation: fit each theory on some conditions, predict held-out ones (dark, marker, "
        "the 2-D shape): which theory generalises",
    ),
    "visualize": (
        "experiments.recording",
        "record a run of the environment in Rerun (--out FILE.rrd, --serve or --spawn)",
    ),
    "view": ("experiments.recording", "open .rrd recordings in Rerun's web viewer on 127.0.0.1 (no display needed)"),
    "train": ("experiments.agents.cli", "train a saccade agent: CEM linear cell policy (default), PPO or SAC"),
    "evaluate": ("experiments.agents.cli", "evaluate a saved, random or heuristic policy; prints one JSON line"),
    "baselines": (
        "experiments.agents.cli",
        "train and evaluate agents x seeds on a task: IQM table with bootstrap CIs and curves",
    ),
}

#: command modules, in the order shown by --help
COMMAND_MODULES = tuple(dict.fromkeys(module for module, _ in COMMANDS.values()))


def _register(module_name: str, subparsers) -> None:
    module = importlib.import_module(module_name)
    register = getattr(module, "add_subcommands", None) or module.add_subcommand
    register(subparsers)


def build_parser(command: str | None = None, *, every: bool | None = None) -> argparse.ArgumentParser:
    """The command-line parser. ``command``: only its module is imported and builds its subparser(s);
    the other commands are listed by name and help (they take no arguments in this parser). Without
    ``command`` (or with ``every=True``) every command module is imported."""
    every = command is None if every is None else every
    parser = HintingParser(
        prog="python -m experiments",
        description="Conformal-camera binocular head: psychophysics, visualization and RL commands.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    chosen = COMMANDS.get(command or "", ("", ""))[0]
    for module_name in COMMAND_MODULES:
        if every or module_name == chosen:
            _register(module_name, sub)
        else:
            for name, (owner, help_text) in COMMANDS.items():
                if owner == module_name:
                    sub.add_parser(name, help=help_text, add_help=False)
    return parser


def chosen_command(argv: list[str]) -> str | None:
    """The command named in ``argv``: its first word that is not an option (the top level takes
    no option with a value)."""
    return next((a for a in argv if not a.startswith("-")), None)


def main(argv: list[str] | None = None) -> int:
    # PyOpenGL logs at INFO that its optional accelerator is absent; pymovements (eye-tracker
    # files) sets the root logger to INFO, which printed that line in the middle of a command's output
    logging.getLogger("OpenGL").setLevel(logging.WARNING)
    argv = sys.argv[1:] if argv is None else list(argv)
    command = chosen_command(argv)
    parser = build_parser(command, every=False)
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    return int(args.func(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
