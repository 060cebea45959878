"""Eye-tracker recordings as they come from labs: EyeLink ASC files (:mod:`.asc`), tables of samples
from any tracker (:mod:`.tables`), and the one way a saccade is measured (:mod:`.kinematics`).
``experiments.oculomotor.eyetracking`` puts them together into a recording's main sequence."""

from .asc import AscData, AscError, parse_asc
from .kinematics import SG_SPAN_MS, engbert_kliegl, measure_saccade, speed_deg_s, steps_ok, velocity
from .tables import PRESETS, Columns, TableError, decode, parse_columns, read_table

__all__ = [
    "AscData",
    "AscError",
    "parse_asc",
    "SG_SPAN_MS",
    "engbert_kliegl",
    "measure_saccade",
    "speed_deg_s",
    "steps_ok",
    "velocity",
    "PRESETS",
    "Columns",
    "TableError",
    "decode",
    "parse_columns",
    "read_table",
]
