"""The project's commands and their one-line help, in the order ``python -m experiments --help``
lists them. Each command ``NAME`` is defined by the module ``experiments.cli.NAME`` (its parser in
``add_subcommand``, its entry function in ``run``); the work is done by the product packages."""

from __future__ import annotations

__all__ = ["HELP", "module_of"]

#: command -> one-line help
HELP: dict[str, str] = {
    "run": "perisaccadic flash-localization study (table, figures, summary, Rerun recording)",
    "saccades": "saccade kinematics vs the published main sequence (figure, table)",
    "phenomena": "which published perisaccadic phenomena each theory predicts (table with CIs, "
    "calibrated/predicted, figures)",
    "fit": "fit a perception model to localization data (maximum likelihood)",
    "compare": "fit several models to the same data and rank them (AIC, BIC, LRT)",
    "simulate": "simulate a localization data set from a model (for recovery checks)",
    "recovery": "model recovery: simulate from each theory, fit every theory, confusion matrix of delta AIC",
    "crossval": "cross-validation: fit each theory on some conditions, predict held-out ones (dark, marker, "
    "the 2-D shape): which theory generalises",
    "visualize": "record a run of the environment in Rerun (--out FILE.rrd, --serve or --spawn)",
    "view": "open .rrd recordings in Rerun's web viewer on 127.0.0.1 (no display needed)",
    "train": "train a saccade agent: CEM linear cell policy (default), PPO or SAC",
    "evaluate": "evaluate a saved, random or heuristic policy; prints one JSON line",
    "baselines": "train and evaluate agents x seeds on a task: IQM table with bootstrap CIs and curves",
}


def module_of(command: str) -> str:
    """The module that defines ``command``."""
    return f"experiments.cli.{command}"
