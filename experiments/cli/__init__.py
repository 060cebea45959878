"""The command line's shared parts: argparse types and the hinting parser (:mod:`.parsing`), and the
options several commands share, each declared once with one range (:mod:`.options`).

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

__all__ = ["GENERATOR_HELP", "DefaultsHelpFormatter", "HintingParser", "amplitude_list", "bounded",
           "check_path_text", "generator_file", "guarded", "int_in", "out_dir", "out_file", "whole_number"]
