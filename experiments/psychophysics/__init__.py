"""Perisaccadic flash-localization psychophysics on the conformal-camera head (paper §6.5, Fig. 11).

Trials run through the environment's pipeline (rendering, retina, DPFT, efference-copy
remapping into the target-centred frame, log-radius shift with a gain time course) and the
perceived flash position is decoded from the remapped map. ``python -m experiments run``
drives a whole study (``experiments.study``).
"""

from .analysis import compression_index, format_summary, sampling_error, summary
from .decode import DEFAULT_THRESHOLD, activity_centroid
from .design import FIG11_OFFSETS_DEG, MORRONE_OFFSETS_DEG, Design, Trial, default_design, quick_design
from .figures import compression_vs_time, fig11, perceived_vs_time, save_all
from .runner import read_table, run_trials, write_parquet
from .targetmap import CentredSamples, TargetCentredMap
from .timecourse import RemapTimeCourse
from .trial import ROW_COLUMNS, TrialConfig, TrialRunner, head_angles_deg

__all__ = [
    "Design", "Trial", "FIG11_OFFSETS_DEG", "MORRONE_OFFSETS_DEG", "default_design", "quick_design",
    "RemapTimeCourse", "TrialConfig", "TrialRunner", "ROW_COLUMNS", "head_angles_deg",
    "TargetCentredMap", "CentredSamples", "activity_centroid", "DEFAULT_THRESHOLD",
    "run_trials", "read_table", "write_parquet",
    "compression_index", "summary", "format_summary", "sampling_error",
    "fig11", "perceived_vs_time", "compression_vs_time", "save_all",
]
