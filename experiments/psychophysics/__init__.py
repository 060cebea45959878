"""Perisaccadic flash-localization psychophysics on the conformal-camera head (paper §6.5, Fig. 11).

Trials run through the environment's pipeline (rendering, retina, DPFT, efference-copy
remapping into the target-centred frame, log-radius shift) and the perceived flash position is
decoded from the remapped map through the eye-position signal and, when seen, the post-saccadic
references; the perception theories are modules of ``theories``, found through its registry. ``python -m experiments run``
drives a whole study (``experiments.psychophysics.study``).

The names below are imported on first use (PEP 562), so that the command line can read the
parameter bounds (``bounds``) without loading MuJoCo.
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "Design": "design",
    "Trial": "design",
    "FIG11_OFFSETS_DEG": "design",
    "MORRONE_OFFSETS_DEG": "design",
    "default_design": "design",
    "quick_design": "design",
    "RemapTimeCourse": "timecourse",
    "TrialConfig": "trial",
    "TrialRunner": "trial",
    "ROW_COLUMNS": "trial",
    "TEXT_COLUMNS": "trial",
    "head_angles_deg": "trial",
    "MODELS": "mechanisms",
    "CONDITIONS": "mechanisms",
    "PARADIGMS": "mechanisms",
    "MECHANISMS": "mechanisms",
    "command_gain": "mechanisms",
    "TargetCentredMap": "targetmap",
    "CentredSamples": "targetmap",
    "activity_centroid": "decode",
    "activity_covariance": "decode",
    "DEFAULT_THRESHOLD": "decode",
    "run_trials": "runner",
    "read_table": "runner",
    "write_parquet": "runner",
    "config_fingerprint": "runner",
    "config_hash": "runner",
    "TABLE_COLUMNS": "runner",
    "FolderBusyError": "runner",
    "compression_index": "analysis",
    "separation_compression": "analysis",
    "displacement_psychometrics": "analysis",
    "summary": "analysis",
    "format_summary": "analysis",
    "sampling_error": "analysis",
    "fig11": "figures",
    "perceived_vs_time": "figures",
    "compression_vs_time": "figures",
    "save_all": "figures",
    "psychometric": "figures",
    "save_displacement": "figures",
    "LIMITS": "bounds",
    "MAX_TRIALS": "bounds",
    "Participant": "participant",
    "PARTICIPANT": "participant",
    "add_report_noise": "participant",
    "read_calibration": "calibration",
    "citation_keys": "calibration",
    "CALIBRATION_CSV": "calibration",
    "SCORE_COLUMNS": "scoring",
    "check_scoreboard": "scoring",
    "finalize": "scoring",
    "theory": "theories",
    "REGISTRY": "theories",
    "example_trials": "snapshots",
    "read_snapshot": "snapshots",
    "write_snapshot": "snapshots",
    "take_snapshot": "snapshots",
    "snapshot_path": "snapshots",
    "scene_state": "snapshots",
    "apply_scene_state": "snapshots",
    "SnapshotError": "snapshots",
    "SNAPSHOT_DIR": "snapshots",
}

__all__ = list(_EXPORTS)


def __getattr__(name: str):
    try:
        module = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
