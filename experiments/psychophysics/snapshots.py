"""Example-trial snapshots: what a trial of the study showed and computed, kept in the results folder
for the study's Rerun recording (``experiments.psychophysics.study.record_study``), so that the recording shows the
trials that ran, not a second run of them.

The examples are one trial per flash time of one saccade amplitude (the amplitude nearest 20 deg), at
one flash position (the offset nearest 8 deg before the target, the first repetition):
:func:`example_trials`. For each, the worker that runs the trial writes
``examples/trial_{id:06d}.npz`` (:data:`SNAPSHOT_DIR`) *before* the trial's row goes into
``trials.csv``; a row without a readable snapshot of the same configuration is run again on resume.

A snapshot holds (arrays; angles in degrees, times in ms):

=====================================  ===========================================================
``config_hash``                        the run's configuration hash (a snapshot of another run is refused)
``trial_id``, ``flash_time_ms``        the trial
``flash_sim_ms``                       the flash's simulated time from the trial's reset
``image``, ``reference``               (2, H, W, 3) uint8: both eyes' frames with the flash, and without
``camera_position``, ``camera_xmat``   (2, 3), (2, 3, 3): the eye cameras at the flash
``pixels_per_unit``                    the eye images' focal length in pixels
``fovea``, ``periphery``, ``coeffs``   (2, N_f, C), (2, M, N, C), (2, M, N, C): each eye's retinal
                                       response to the flash (flash minus no-flash) and its DPFT: what
                                       the read-out used
``qpos``, ``mocap_pos``, ``mocap_quat``, ``geom_rgba``   the MuJoCo scene at the flash (3-D replay)
``flash_world``                        (3,) the flash's world position
``trace_ms``                           (T,) times re saccade onset, every :data:`TRACE_STEP_MS`
``angles``, ``signal``                 (T, 2, 3) the plan's eye angles and the eye-position signal
=====================================  ===========================================================
"""

from __future__ import annotations

import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from .design import Design, Trial

__all__ = [
    "SNAPSHOT_DIR",
    "TRACE_STEP_MS",
    "TRACE_MARGIN_MS",
    "example_trials",
    "take_snapshot",
    "scene_state",
    "apply_scene_state",
    "snapshot_path",
    "write_snapshot",
    "read_snapshot",
    "SnapshotError",
]

SNAPSHOT_DIR = "examples"
#: The example trial's eye trace: one sample every TRACE_STEP_MS, from the earliest flash time minus
#: TRACE_MARGIN_MS to the latest plus TRACE_MARGIN_MS (re saccade onset).
TRACE_STEP_MS = 2.0
TRACE_MARGIN_MS = 100.0
_KEYS = (
    "config_hash",
    "trial_id",
    "flash_time_ms",
    "flash_sim_ms",
    "image",
    "reference",
    "camera_position",
    "camera_xmat",
    "pixels_per_unit",
    "fovea",
    "periphery",
    "coeffs",
    "qpos",
    "mocap_pos",
    "mocap_quat",
    "geom_rgba",
    "flash_world",
    "trace_ms",
    "angles",
    "signal",
)


class SnapshotError(ValueError):
    """A snapshot file is missing, unreadable, incomplete or of another run."""


def example_trials(design: Design, amplitude_deg: float | None = None) -> list[Trial]:
    """One trial per flash time (in time order) of the amplitude nearest ``amplitude_deg`` (default
    20 deg), at the flash offset nearest (-8, 0) deg from the target, first repetition."""
    trials = design.trials()
    amps = np.array(sorted({t.amplitude_deg for t in trials}))
    a = float(amps[np.argmin(np.abs(amps - (20.0 if amplitude_deg is None else float(amplitude_deg))))])
    offsets = sorted(
        {(t.flash_dx_deg, t.flash_dy_deg) for t in trials if t.amplitude_deg == a},
        key=lambda o: (abs(o[0] + 8.0) + abs(o[1]), o),
    )
    dx, dy = offsets[0]
    chosen: dict[int, Trial] = {}
    for t in trials:
        if t.amplitude_deg == a and (t.flash_dx_deg, t.flash_dy_deg) == (dx, dy) and t.flash_time_ms not in chosen:
            chosen[t.flash_time_ms] = t
    return [chosen[k] for k in sorted(chosen)]


def _trace_times(design: Design) -> np.ndarray:
    lo = min(design.flash_times_ms) - TRACE_MARGIN_MS
    hi = max(design.flash_times_ms) + TRACE_MARGIN_MS
    return np.arange(lo, hi + TRACE_STEP_MS / 2, TRACE_STEP_MS)


def take_snapshot(runner, trial: Trial, row: dict, design: Design, config_hash: str) -> dict[str, np.ndarray]:
    """The snapshot of ``trial`` just run by ``runner`` (a ``TrialRunner`` whose ``last`` holds its
    frames, maps, plan and scene state) with its table ``row``."""
    last = runner.last
    if not last or "scene" not in last:
        raise ValueError("take_snapshot needs the runner's last localization or separation trial")
    frame, ref, plan, scene = last["frame"], last["reference"], last["plan"], last["scene"]
    views = [m[0] for m in last["maps"]]
    t_ms = _trace_times(design)
    abs_ms = float(plan.onset_ms) + t_ms
    return {
        "config_hash": np.array(config_hash),
        "trial_id": np.array(trial.trial_id),
        "flash_time_ms": np.array(trial.flash_time_ms),
        "flash_sim_ms": np.array(float(row["flash_sim_ms"])),
        "image": np.stack([frame.left.image, frame.right.image]).astype(np.uint8),
        "reference": np.stack([ref.left.image, ref.right.image]).astype(np.uint8),
        "camera_position": np.stack([frame.left.camera_position, frame.right.camera_position]).astype(float),
        "camera_xmat": np.stack(
            [np.reshape(frame.left.camera_xmat, (3, 3)), np.reshape(frame.right.camera_xmat, (3, 3))]
        ).astype(float),
        "pixels_per_unit": np.array(float(frame.left.pixels_per_unit)),
        "fovea": np.stack([v.fovea for v in views]).astype(np.float32),
        "periphery": np.stack([v.periphery for v in views]).astype(np.float32),
        "coeffs": np.stack([v.coeffs for v in views]).astype(np.complex64),
        **{k: np.asarray(v) for k, v in scene.items()},
        "trace_ms": t_ms,
        "angles": np.degrees(plan.angles(abs_ms)),
        "signal": np.degrees(plan.eye_position_signal(abs_ms)),
    }


def scene_state(head) -> dict[str, np.ndarray]:
    """The MuJoCo state that places the scene's bodies and shows its geoms (for a 3-D replay):
    ``qpos``, ``mocap_pos``, ``mocap_quat`` and ``geom_rgba`` (flashes shown through their alpha);
    ``models.Head.scene_state``."""
    return head.scene_state()


def apply_scene_state(head, snap: dict[str, np.ndarray]) -> None:
    """Put ``head``'s scene in the state of :func:`scene_state` (positions only: no simulation)."""
    for key, arr in head.scene_state().items():
        if np.shape(snap[key]) != arr.shape:
            raise SnapshotError(f"the snapshot's {key} has shape {np.shape(snap[key])}; this scene's is {arr.shape}")
    head.set_scene_state(snap)


def snapshot_path(out: str | os.PathLike, trial_id: int) -> Path:
    """Where the snapshot of trial ``trial_id`` lives in results folder ``out``."""
    return Path(out) / SNAPSHOT_DIR / f"trial_{int(trial_id):06d}.npz"


def write_snapshot(out: str | os.PathLike, snap: dict[str, np.ndarray]) -> Path:
    """Write a snapshot atomically (a temporary file renamed into place); returns its path."""
    path = snapshot_path(out, int(snap["trial_id"]))
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as fh:
        # Any: numpy's stubs match the ** entries against savez_compressed's allow_pickle: bool as well
        entries: dict[str, Any] = snap
        np.savez_compressed(fh, **entries)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    return path


def read_snapshot(out: str | os.PathLike, trial_id: int, config_hash: str | None = None) -> dict[str, np.ndarray]:
    """The snapshot of ``trial_id`` in ``out``, checked whole (every array read: the zip's CRCs) and,
    if ``config_hash`` is given, of that run; ``SnapshotError`` says what is wrong."""
    path = snapshot_path(out, trial_id)
    if not path.is_file():
        raise SnapshotError(
            f"{path} is missing; run the study again on the same folder (python -m experiments run "
            "--out FOLDER with the same options) to run that trial again and rewrite it"
        )
    try:
        with np.load(path, allow_pickle=False) as z:
            missing = [k for k in _KEYS if k not in z.files]
            if missing:
                raise SnapshotError(
                    f"{path} lacks {', '.join(missing)}; delete it and run the study again on the same folder to rewrite it"
                )
            snap = {k: z[k] for k in _KEYS}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as e:
        if isinstance(e, SnapshotError):
            raise
        raise SnapshotError(
            f"{path} cannot be read ({e}); delete it and run the study again on the same folder to rewrite it"
        ) from None
    if int(snap["trial_id"]) != int(trial_id):
        raise SnapshotError(f"{path} holds trial {int(snap['trial_id'])}, not {trial_id}")
    if config_hash is not None and str(snap["config_hash"]) != config_hash:
        raise SnapshotError(
            f"{path} belongs to another run (config_hash {snap['config_hash']}, this run {config_hash})"
        )
    return snap
