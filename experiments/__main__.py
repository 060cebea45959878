"""``python -m experiments COMMAND``: the project's commands.

run        perisaccadic flash-localization study (table, figures, summary, Rerun recording)
saccades   saccade kinematics and the eye-position signal against published data (figure, table)
phenomena  which published perisaccadic phenomena each theory predicts (table with CIs, figures)
fit        fit a perception model to localization data (maximum likelihood; local or Ray)
compare    fit several models to the same data and rank them (AIC, BIC, likelihood-ratio tests)
simulate   simulate a localization data set from a model
recovery   model recovery: simulate from each theory, fit every theory (confusion matrix of delta AIC)
visualize  record a run of the environment in Rerun (``--out FILE.rrd``, ``--spawn`` or ``--serve``)
view       open .rrd recordings in Rerun's web viewer on 127.0.0.1 (Ctrl-C / SIGTERM leave nothing behind)
train      train a saccade agent on a task
evaluate   evaluate a saved, random or heuristic policy
baselines  train and evaluate agents x seeds on a task: held-out IQM table with bootstrap CIs, curves

Each command is defined in its own module by ``add_subcommand(subparsers)``, which registers
its arguments and sets ``func`` to the function that runs it.
"""

from __future__ import annotations

import argparse
import importlib
import sys

# command modules, in the order shown by --help
COMMAND_MODULES = ("experiments.study", "experiments.saccades", "experiments.phenomena", "experiments.modelfit.cli",
                   "experiments.modelfit.recovery", "experiments.recording", "experiments.rl")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m experiments",
        description="Conformal-camera binocular head: psychophysics, visualization and RL commands.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        module = importlib.import_module(name)
        getattr(module, "add_subcommands", None) and module.add_subcommands(sub)
        getattr(module, "add_subcommand", None) and module.add_subcommand(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    return int(args.func(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
