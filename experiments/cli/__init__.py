"""The command line's shared parts: argparse types and the hinting parser (:mod:`.parsing`), and the
options several commands share, each declared once with one range (:mod:`.options`), and the stage
lines and warm-up-aware progress bars on stderr (:mod:`.progress`).

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
