"""The study's Rerun recording, made from what the study computed (no trial is run again)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["record_study"]


def record_study(out: Path, table: dict, design, config, path: Path | None = None) -> Path:
    """The study's Rerun recording (default ``out/study.rrd``), made from what the study computed: the
    trials table and the example trials' snapshots in ``out/examples`` (``psychophysics.snapshots``,
    written as the trials ran). No trial is run again: the scene is only posed from each snapshot.

    Timelines (``experiments.recording.TIMELINES``): ``trial`` (each trial's true and perceived flash
    in ``study/true``, ``study/perceived``, ``study/error``), ``flash_time`` (ms re saccade onset: every trial of the example amplitude at that
    flash time, the compression index and the mean remapping gain per amplitude, the example trial's eye
    trace, and the example trial of that flash time in full) and ``sim_time`` (the example trials'
    flash instants, for the 3-D replay). The recording is the same for a resumed and an uninterrupted
    run of the same design (its recording id is the configuration hash; no wall-clock log time)."""
    import types

    import rerun as rr
    from threadpoolctl import threadpool_limits

    from ...recording import STUDY_APP_ID, Recorder
    from .. import TrialRunner, compression_index, config_hash
    from ..snapshots import apply_scene_state, example_trials, read_snapshot

    out = Path(out)
    path = out / "study.rrd" if path is None else Path(path)
    chash = config_hash(design, config)
    examples = example_trials(design)
    snaps = [read_snapshot(out, t.trial_id, chash) for t in examples]
    a = examples[0].amplitude_deg
    flip = np.array([1.0, -1.0])
    dot = rr.components.Radius.ui_points(4.0)
    order = np.argsort(table["trial_id"], kind="stable")
    col = {k: np.asarray(v)[order] for k, v in table.items()}
    row_of = {int(i): k for k, i in enumerate(col["trial_id"])}
    with threadpool_limits(limits=1):
        runner = TrialRunner(config)  # its head is only posed (apply_scene_state) and its retina samples images
        try:
            with Recorder(path, app_id=STUDY_APP_ID, recording_id=f"{STUDY_APP_ID}-{chash}", log_time=False) as rec:
                # ---- trial: every trial of the table
                true = np.column_stack([col["true_x_deg"], col["true_y_deg"]]) * flip
                seen = np.column_stack([col["perceived_x_deg"], col["perceived_y_deg"]]) * flip
                n = len(col["trial_id"])
                by_trial = [rr.TimeColumn("trial", sequence=col["trial_id"].astype(np.int64))]
                ones = np.ones(n, int)  # one point per trial, sent as columns (a few chunks, not n rows)
                for entity, pts, rgb in (("study/true", true, [40, 200, 40]), ("study/perceived", seen, [230, 40, 40])):
                    rec.send_columns(
                        entity,
                        by_trial,
                        rr.Points2D.columns(
                            positions=pts, colors=np.tile(rgb, (n, 1)), radii=np.full(n, -4.0)
                        ).partition(ones),
                    )  # -4: 4 UI points
                rec.send_columns(
                    "study/error",
                    by_trial,
                    rr.Arrows2D.columns(
                        vectors=seen - true, origins=true, colors=np.tile([200, 200, 200], (n, 1))
                    ).partition(ones),
                )
                rec.reset_time()
                # ---- flash_time: per flash time, all trials of the example amplitude; CI and gain per amplitude
                sel = col["saccade_amplitude_deg"] == a
                for t in np.unique(col["flash_time_ms"][sel]):
                    m = sel & (col["flash_time_ms"] == t)
                    rec.set_time("flash_time", float(t))
                    rec.log("study/true", rr.Points2D(true[m], radii=dot, colors=[[40, 200, 40]]))
                    rec.log("study/perceived", rr.Points2D(seen[m], radii=dot, colors=[[230, 40, 40]]))
                    rec.log(
                        "study/error", rr.Arrows2D(vectors=seen[m] - true[m], origins=true[m], colors=[[200, 200, 200]])
                    )
                rec.reset_time()
                for amp, (tt, vals) in compression_index(col).items():
                    rec.send_scalars(
                        f"study/compression_index/{amp:g}deg",
                        [rr.TimeColumn("flash_time", duration=np.asarray(tt, float) / 1000.0)],
                        vals,
                    )
                for amp in np.unique(col["saccade_amplitude_deg"]):
                    ma = col["saccade_amplitude_deg"] == amp
                    tt = np.unique(col["flash_time_ms"][ma])
                    gain = [float(np.mean(col["gain"][ma & (col["flash_time_ms"] == t)])) for t in tt]
                    rec.send_scalars(
                        f"study/gain/{amp:g}deg",
                        [rr.TimeColumn("flash_time", duration=np.asarray(tt, float) / 1000.0)],
                        gain,
                    )
                ex = snaps[int(np.argmin([abs(int(s["flash_time_ms"])) for s in snaps]))]  # the trace nearest 0 ms
                tcol = [rr.TimeColumn("flash_time", duration=np.asarray(ex["trace_ms"], float) / 1000.0)]
                for e, eye in enumerate(("left", "right")):
                    for j, ax in enumerate(("h", "v")):
                        rec.send_scalars(f"eyes/{eye}/angle/{ax}", tcol, ex["angles"][:, e, j])
                        rec.send_scalars(f"eyes/{eye}/signal/{ax}", tcol, ex["signal"][:, e, j])
                # ---- each example trial in full, at its flash time and its flash's sim time (3-D replay)
                grid = runner.retina_grid
                for trial, snap in zip(examples, snaps):
                    rec.set_time_ms(float(snap["flash_sim_ms"]))
                    rec.set_time("flash_time", float(trial.flash_time_ms))
                    apply_scene_state(runner.head, snap)
                    rec.log_head(runner.head)
                    rec.log("world/flashes", rr.Points3D([snap["flash_world"]], radii=0.015, colors=[[255, 255, 0]]))
                    eyes = [
                        types.SimpleNamespace(
                            image=snap["image"][e],
                            camera_position=snap["camera_position"][e],
                            camera_xmat=snap["camera_xmat"][e],
                            pixels_per_unit=float(snap["pixels_per_unit"]),
                        )
                        for e in range(2)
                    ]
                    rec.log_frame(types.SimpleNamespace(left=eyes[0], right=eyes[1]), grid)
                    scene_views = [runner.vision.see(snap["image"][e]) for e in range(2)]
                    flash_views = [
                        types.SimpleNamespace(
                            fovea=snap["fovea"][e], periphery=snap["periphery"][e], coeffs=snap["coeffs"][e]
                        )
                        for e in range(2)
                    ]
                    rec.log_views(scene_views, grid, dpft=flash_views, cortex=flash_views)
                    rec.log_flash_response(flash_views, grid)
                    k = row_of[trial.trial_id]
                    rec.log_flash(
                        (col["true_x_deg"][k], col["true_y_deg"][k]),
                        (col["perceived_x_deg"][k], col["perceived_y_deg"][k]),
                        (a / 2, 0.0),
                        (-a / 2, 0.0),
                    )
        finally:
            runner.close()
    return path
