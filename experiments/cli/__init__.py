"""The command line ``python -m experiments COMMAND``.

One module per command (``run``, ``saccades``, ``phenomena``, ``fit``, ``compare``, ``simulate``,
``recovery``, ``crossval``, ``visualize``, ``view``, ``train``, ``evaluate``, ``baselines``): its
``add_subcommand`` builds the parser and its ``run`` turns the options into calls of the product's
functions, importing heavy code only there. The table of commands (:mod:`.commands`); argparse types
and the hinting parser (:mod:`.parsing`); the options several commands share, each declared once with
one range (:mod:`.options`); ``TrialConfig``'s fields as options (:mod:`.trialconfig`); ``fit``'s,
``compare``'s and ``simulate``'s common parts (:mod:`.fitting`); the stage lines and warm-up-aware
progress bars on stderr (:mod:`.progress`).

Importing this package imports no command module, numba, MuJoCo, torch or Rerun.
"""

from .parsing import (
    GENERATOR_HELP,
    DefaultsHelpFormatter,
    HintingParser,
    amplitude_list,
    bounded,
    check_path_text,
    generator_file,
    guarded,
    int_in,
    out_dir,
    out_file,
    whole_number,
)
from .progress import WARMUP, Progress, stage

__all__ = [
    "GENERATOR_HELP",
    "WARMUP",
    "DefaultsHelpFormatter",
    "HintingParser",
    "Progress",
    "amplitude_list",
    "bounded",
    "check_path_text",
    "generator_file",
    "guarded",
    "int_in",
    "out_dir",
    "out_file",
    "stage",
    "whole_number",
]
