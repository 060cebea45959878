"""Recordings a person reads at a glance: every picture scaled to show its content, timelines in the
units people think in, the study's recording made from the trials that ran (and the same after a
resume), labels that do not overlap, panels titled in words, no float noise in the plots, and
servers that leave nothing behind when stopped."""

from __future__ import annotations

import math
import os
import signal
import socket
import subprocess
import sys
import time

import numpy as np
import pyarrow as pa
import pytest
from rerun.chunk import RrdReader

from experiments.recording.colour import colormap_lut, contrast, gain_scaled, log_scaled, symmetric_scaled
from procs import children as _children  # tests/procs.py
from procs import gone
from test_recording import check_blueprint, read_blueprint  # tests/test_recording.py's blueprint readers

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


# ------------------------------------------------------------------ reading recordings back
def chunks(path) -> dict[str, list[dict]]:
    """entity -> list of rows {timeline: value, ..., "cols": {column: value}} (static rows: no timeline)."""
    out: dict[str, list[dict]] = {}
    for chunk in RrdReader(str(path)).store().stream().to_chunks():
        b = chunk.to_record_batch()
        kinds = {f.name: f.type for f in b.schema}
        times = [n for n, t in kinds.items() if not n.startswith("rerun.") and not pa.types.is_list(t)
                 and not pa.types.is_large_list(t)]
        cols = [n for n, t in kinds.items() if pa.types.is_list(t) or pa.types.is_large_list(t)]
        tcols = {n: b.column(n).cast(pa.int64()).to_pylist() for n in times}
        vals = {n: b.column(n).to_pylist() for n in cols}
        for i in range(b.num_rows):
            row = {n: tcols[n][i] for n in times if tcols[n][i] is not None}
            row["cols"] = {n: vals[n][i] for n in cols if vals[n][i] is not None}
            out.setdefault(chunk.entity_path, []).append(row)
    return out


def content(path) -> dict[str, list]:
    """A recording's data independent of how Rerun batched it into chunks: entity -> sorted rows
    (without ``/__properties``: RecordingInfo's start time, the wall-clock time it was written)."""
    import json

    return {e: sorted(json.dumps({k: v for k, v in r.items() if k != "cols"} | {"cols": r["cols"]}, sort_keys=True,
                                 default=str) for r in rows)
            for e, rows in chunks(path).items() if e != "/__properties"}


def pictures(path):
    """(entity, uint8 picture) of every Image logged in the recording."""
    for entity, rows in chunks(path).items():
        for r in rows:
            fmt = r["cols"].get("Image:format")
            if fmt is None:
                continue
            fmt = fmt[0]
            buf = np.asarray(r["cols"]["Image:buffer"][0], np.uint8)
            chans = {1: 1, 2: 3, 3: 4}[fmt["color_model"]]
            yield entity, buf.reshape(fmt["height"], fmt["width"], chans)


# ------------------------------------------------------------------ fixtures: a tiny study, a short env run
def _design():
    from experiments.psychophysics import Design

    return Design(amplitudes_deg=(20.0,), flash_offsets_deg=((-8.0, 0.0), (4.0, 0.0)), flash_times_ms=(-50, 0),
                  repetitions=1, seed=0, name="tiny")


def _config():
    from experiments.psychophysics import TrialConfig

    return TrialConfig(image_size=128)


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    from experiments.psychophysics.study import run_study

    out = tmp_path_factory.mktemp("study")
    res = run_study(_design(), _config(), out, workers=1, progress=False, formats=("png",))
    return out, res


@pytest.fixture(scope="module")
def env_run(tmp_path_factory):
    from experiments.recording import record_env_run

    path = tmp_path_factory.mktemp("env") / "run.rrd"
    record_env_run(path, steps=2, seed=3, image_size=96, fixation_ms=120)
    return path


# ------------------------------------------------------------------ 1. every picture shows its content
def test_gain_scaled_against_direct_computation():
    a = np.array([[0.0, 0.01], [0.02, 0.04]])
    pix, rng = gain_scaled(a, "gray")
    assert rng == (0.0, 0.04)
    np.testing.assert_array_equal(pix[..., 0], np.rint(a / 0.04 * 255).astype(np.uint8))
    rgb = np.zeros((2, 2, 3))
    rgb[0, 0] = (0.02, 0.01, 0.0)  # hue kept: all channels share the gain
    pix, _ = gain_scaled(rgb)
    assert pix[0, 0].tolist() == [255, 128, 0]
    pix, rng = gain_scaled(np.zeros((3, 3)))
    assert rng == (0.0, 0.0) and np.all(pix == colormap_lut("gray")[0])
    with pytest.raises(ValueError):
        gain_scaled(np.array([[-1.0, 1.0]]))
    with pytest.raises(ValueError):
        gain_scaled(np.array([[np.nan, 1.0]]))


def test_symmetric_scaled_puts_zero_in_the_middle():
    a = np.array([[-2.0, 0.0, 1.0]])
    pix, rng = symmetric_scaled(a)
    lut = colormap_lut("RdBu_r")
    assert rng == (-2.0, 2.0)
    assert pix[0, 0].tolist() == lut[0].tolist() and pix[0, 2].tolist() == lut[191].tolist()
    assert pix[0, 1].tolist() in (lut[127].tolist(), lut[128].tolist())


def test_log_scaled_spans_the_magnitudes_decades():
    mag = np.array([[1e-6, 1e-3, 1e-2, 1e-1, 1.0]])
    pix, (lo, hi) = log_scaled(mag, decades=3)
    assert (lo, hi) == (pytest.approx(-3.0), pytest.approx(0.0))
    lut = colormap_lut("viridis")
    idx = [int(np.argmin(((lut.astype(int) - p.astype(int)) ** 2).sum(-1))) for p in pix[0]]
    assert idx == [0, 0, 85, 170, 255]
    _, (lo, hi) = log_scaled(np.array([[0.5, 1.0]]))  # fewer decades than 3: its own range
    assert lo == pytest.approx(math.log10(0.5)) and hi == pytest.approx(0.0)


@pytest.mark.slow  # a study of 4 trials or an env run (module fixtures), or a server
@pytest.mark.parametrize("which", ["study", "env"])
def test_every_logged_picture_has_contrast(which, request):
    """No picture is nearly black (its brightest pixel reaches half of full scale, and its spread is at
    least a fifth of it) or washed out (at most 95 % of its pixels at 255: a fixated dot filling three
    quarters of the fovea is content, a panel at full scale is not), on the bundled dots scene: the
    study's and a run's recording."""
    path = request.getfixturevalue("study")[0] / "study.rrd" if which == "study" else request.getfixturevalue("env_run")
    seen = set()
    for entity, pix in pictures(path):
        spread, saturated = contrast(pix[..., :3])
        assert pix[..., :3].max() >= 128, (entity, pix.max())  # its brightest channel (a red dot counts)
        assert spread >= 0.2 and saturated <= 0.95, (entity, spread, saturated)
        seen.add(entity)
    expected = {"/retina/left/fovea", "/retina/right/logpolar", "/dpft/left/log_magnitude", "/cortex/map",
                "/eyes/left/image"} | ({"/retina/left/flash_response"} if which == "study" else
                                        {"/remap/left/difference", "/remap/right/predicted"})
    assert expected <= seen, expected - seen


# ------------------------------------------------------------------ 2. timelines people think in
@pytest.mark.slow  # a study of 4 trials or an env run (module fixtures), or a server
def test_study_timelines_are_flash_time_trial_and_sim_time(study):
    out, res = study
    from experiments.psychophysics import read_table

    table = read_table(res["table"])
    c = chunks(out / "study.rrd")
    ft = sorted({r["flash_time"] for r in c["/study/true"] if "flash_time" in r})
    assert ft == [-50_000_000, 0]  # ms re saccade onset, as durations in ns
    trials = sorted(r["trial"] for r in c["/study/true"] if "trial" in r)
    assert trials == sorted(table["trial_id"].tolist())
    assert not any("log_time" in r for rows in c.values() for r in rows)  # no wall clock: reproducible
    # the example trials' images sit at their flash time and at their flash's sim time (3-D replay)
    imgs = [r for r in c["/eyes/left/image"]]
    assert sorted(r["flash_time"] for r in imgs) == [-50_000_000, 0]
    assert all("sim_time" in r for r in imgs)
    trace = [r for r in c["/eyes/left/angle/h"]]
    assert all("flash_time" in r and "sim_time" not in r for r in trace)


@pytest.mark.slow  # a study of 4 trials or an env run (module fixtures), or a server
def test_env_recording_has_env_step_and_episode(env_run):
    c = chunks(env_run)
    steps = {r["env_step"] for rows in c.values() for r in rows if "env_step" in r}
    assert steps == {0, 1, 2}
    assert {r["episode"] for rows in c.values() for r in rows if "episode" in r} == {0}
    imgs = c["/eyes/left/image"]
    assert [r["env_step"] for r in sorted(imgs, key=lambda r: r["sim_time"])] == [0, 1, 1, 2, 2]  # reset, flash, end


# ------------------------------------------------------------------ 3. record what ran
@pytest.mark.slow  # a study of 4 trials or an env run (module fixtures), or a server
def test_study_blueprint_shows_every_entity_of_the_study(study):
    """Every view of the ``study`` layout shows some entity of ``study.rrd`` that it can draw, and every
    entity with data is in some view; no run-only entity (remapping, saccade statistics, target) is in it."""
    out, _ = study
    check_blueprint(out / "study.rrd")
    names = set(chunks(out / "study.rrd"))
    assert not any(k.startswith(("/remap", "/saccades")) or (k.startswith("/eyes") and k.endswith("/target"))
                   for k in names)
    assert {"/world/flashes", "/world/labels", "/cortex/labels", "/study/gain/20deg",
            "/study/compression_index/20deg"} <= names


@pytest.mark.slow  # a study of 4 trials or an env run (module fixtures), or a server
def test_study_recording_shows_the_table(study):
    """study/true and study/perceived at each flash time are the table's trials of that time."""
    out, res = study
    from experiments.psychophysics import read_table

    t = read_table(res["table"])
    c = chunks(out / "study.rrd")
    for r in c["/study/perceived"]:
        if "flash_time" not in r:
            continue
        m = t["flash_time_ms"] == r["flash_time"] / 1e6
        got = np.asarray(r["cols"]["Points2D:positions"], float)
        want = np.column_stack([t["perceived_x_deg"][m], -t["perceived_y_deg"][m]])
        np.testing.assert_allclose(got, want, atol=1e-5)


@pytest.mark.slow  # a study of 4 trials or an env run (module fixtures), or a server
def test_recording_runs_no_trial_and_resumed_run_records_the_same(study, tmp_path, monkeypatch):
    """The recording is made from the table and the snapshots alone (a TrialRunner that cannot run
    trials makes the same file); a run interrupted after one trial and resumed records the same."""
    from experiments.psychophysics import read_table, run_trials
    from experiments.psychophysics.trial import TrialRunner
    from experiments.psychophysics.study import record_study, run_study

    out, res = study
    ref = content(out / "study.rrd")

    def refuse(*a, **k):
        raise AssertionError("record_study ran a trial")

    with monkeypatch.context() as m:
        m.setattr(TrialRunner, "run", refuse)
        m.setattr(TrialRunner, "observe", refuse)
        again = record_study(out, read_table(res["table"]), _design(), _config(), path=tmp_path / "again.rrd")
    assert content(again) == ref
    resumed = tmp_path / "resumed"
    from experiments.psychophysics.snapshots import example_trials

    keep = [t.trial_id for t in example_trials(_design())]
    run_trials(_design(), _config(), resumed, workers=1, progress=False, limit=1, examples=keep)
    run_study(_design(), _config(), resumed, workers=1, progress=False, formats=("png",))
    assert content(resumed / "study.rrd") == ref


@pytest.mark.slow  # a study of 4 trials or an env run (module fixtures), or a server
def test_lost_or_foreign_snapshots_are_run_again_and_bad_ones_refused(study, tmp_path, capsys):
    import shutil as sh

    from experiments.psychophysics import read_table, run_trials
    from experiments.psychophysics.snapshots import SnapshotError, example_trials, snapshot_path
    from experiments.psychophysics.study import record_study

    out, res = study
    work = tmp_path / "copy"
    sh.copytree(out, work)
    ids = [t.trial_id for t in example_trials(_design())]
    before = np.load(snapshot_path(work, ids[0]))["angles"].copy()
    snapshot_path(work, ids[0]).unlink()
    snapshot_path(work, ids[1]).write_bytes(b"not a zip")
    with pytest.raises(SnapshotError, match="is missing; run the study again"):
        record_study(work, read_table(res["table"]), _design(), _config(), path=tmp_path / "x.rrd")
    snapshot_path(work, ids[0]).write_bytes(b"")
    with pytest.raises(SnapshotError, match="cannot be read"):
        record_study(work, read_table(res["table"]), _design(), _config(), path=tmp_path / "x.rrd")
    run_trials(_design(), _config(), work, workers=1, progress=False, examples=ids)
    assert "2 example trial(s) without a readable snapshot" in capsys.readouterr().err
    np.testing.assert_array_equal(np.load(snapshot_path(work, ids[0]))["angles"], before)  # the same trial again
    assert read_table(work / "trials.csv")["trial_id"].tolist() == read_table(res["table"])["trial_id"].tolist()
    record_study(work, read_table(work / "trials.csv"), _design(), _config(), path=tmp_path / "y.rrd")
    assert content(tmp_path / "y.rrd") == content(out / "study.rrd")


# ------------------------------------------------------------------ 4. readable
def test_blueprint_panels_are_titled_in_words(tmp_path):
    import rerun as rr

    from experiments.recording.blueprint import blueprint

    for layout, timeline in (("run", "sim_time"), ("study", "flash_time")):
        path = str(tmp_path / f"{layout}.rrd")
        rec = rr.RecordingStream("t", recording_id=layout)
        rec.save(path, default_blueprint=blueprint(layout))
        rec.disconnect()
        bp = read_blueprint(path)
        names = [v["name"] for v in bp["views"].values()]
        for n in names:
            assert len(n.split()) >= 4 and not n.startswith(("eyes/", "retina/", "dpft/", "cortex/")), n
        assert bp["time_panel"]["TimePanelBlueprint:timeline"] == [timeline]
        words = " ".join(names)
        for what in ("sees", "retina", "DPFT", "cortex", "percept"):
            assert what in words, (layout, what)


def _label_boxes(positions, labels, eye, look, fov_y_deg=55.0, size=(800, 380), char_px=7.5, height_px=18):
    """Screen boxes (x0, y0, x1, y1) of 3-D labels, each centred on its point, seen from ``eye``
    looking at ``look`` (z up) by a pinhole of vertical field ``fov_y_deg`` in a panel of ``size``
    pixels; a label is ``char_px`` per character + 8 px wide and ``height_px`` tall."""
    eye, look = np.asarray(eye, float), np.asarray(look, float)
    f = (look - eye) / np.linalg.norm(look - eye)
    r = np.cross(f, [0.0, 0.0, 1.0])
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    s = size[1] / 2 / math.tan(math.radians(fov_y_deg) / 2)
    boxes = []
    for p, lab in zip(positions, labels):
        d = np.asarray(p, float) - eye
        x, y = size[0] / 2 + s * (d @ r) / (d @ f), size[1] / 2 - s * (d @ u) / (d @ f)
        w = char_px * len(lab) + 8
        boxes.append((x - w / 2, y - height_px / 2, x + w / 2, y + height_px / 2))
    return boxes


@pytest.mark.slow  # a study of 4 trials or an env run (module fixtures), or a server
@pytest.mark.parametrize("which", ["study", "env"])
def test_3d_labels_do_not_overlap_at_the_default_camera(which, request):
    """Only the fixation point and the target are labelled (``world/labels``; the other objects are
    unlabelled points), and at the 3-D view's default camera their labels' boxes do not overlap, in
    the 800 x 380 px panel of the README's 1600 x 1000 screenshot (Rerun's default vertical field of
    view, 55 deg, assumed; 7.5 px per character, 18 px high). The unlabelled placement (labels on the
    points themselves) overlaps for the env run's target 9 deg below-right of fixation."""
    from experiments.recording.blueprint import SCENE_EYE_POSITION, SCENE_LOOK_TARGET

    path = request.getfixturevalue("study")[0] / "study.rrd" if which == "study" else request.getfixturevalue("env_run")
    c = chunks(path)
    assert all(not r["cols"].get("Points3D:labels") for r in c["/world/objects"])
    for r in c["/world/labels"]:
        labels = r["cols"]["Points3D:labels"]
        assert sorted(labels) == ["fixation", "target"]
        boxes = _label_boxes(r["cols"]["Points3D:positions"], labels, SCENE_EYE_POSITION, SCENE_LOOK_TARGET)
        (a0, b0, a1, b1), (c0, d0, c1, d1) = boxes
        assert a1 <= c0 or c1 <= a0 or b1 <= d0 or d1 <= b0, boxes


def test_label_placement_separates_objects_whose_labels_would_overlap(tmp_path):
    """A target 5 deg right of fixation at the same height: labels on the points overlap in the default
    view; placed by the recorder (the first of equal heights above, the other below), they do not."""
    from experiments.recording.blueprint import SCENE_EYE_POSITION, SCENE_LOOK_TARGET
    from experiments.recording import Recorder

    fix, tgt = np.array([1.082, 0.0, 1.2]), np.array([1.082, -1.082 * math.tan(math.radians(5)), 1.2])
    names = ["fixation", "target"]
    (a0, b0, a1, b1), (c0, d0, c1, d1) = _label_boxes([fix, tgt], names, SCENE_EYE_POSITION, SCENE_LOOK_TARGET)
    assert not (a1 <= c0 or c1 <= a0 or b1 <= d0 or d1 <= b0)  # on the points: overlap
    with Recorder(tmp_path / "l.rrd", recording_id="l") as rec:
        rec.set_time_ms(0)
        rec._log_labels(names, [fix, tgt])
    r = chunks(tmp_path / "l.rrd")["/world/labels"][0]["cols"]
    (a0, b0, a1, b1), (c0, d0, c1, d1) = _label_boxes(r["Points3D:positions"], r["Points3D:labels"],
                                                      SCENE_EYE_POSITION, SCENE_LOOK_TARGET)
    assert a1 <= c0 or c1 <= a0 or b1 <= d0 or d1 <= b0


@pytest.mark.slow  # a study of 4 trials or an env run (module fixtures), or a server
def test_plotted_scalars_have_no_float_noise(env_run, study):
    for path in (env_run, study[0] / "study.rrd"):
        for entity, rows in chunks(path).items():
            for r in rows:
                v = r["cols"].get("Scalars:scalars")
                if v is not None:
                    v = np.asarray(v, float)
                    assert np.all(v == np.round(v, 6)), entity
                    assert not np.any((v != 0) & (np.abs(v) < 1e-6)), entity


# ------------------------------------------------------------------ 6. clean exit
def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _port_free(port: int) -> bool:
    with socket.socket() as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


@pytest.mark.slow  # a study of 4 trials or an env run (module fixtures), or a server
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("command,sig", [("view", signal.SIGTERM), ("view", signal.SIGINT),
                                         ("visualize", signal.SIGTERM)])
def test_serving_commands_leave_no_server_or_port_behind(command, sig, env_run, tmp_path):
    web, grpc = _free_port(), _free_port()
    args = (["view", str(env_run)] if command == "view" else
            ["visualize", "--serve", "--steps", "1", "--image-size", "32", "--no-progress"])
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    proc = subprocess.Popen([sys.executable, "-m", "experiments", *args, "--web-port", str(web), "--grpc-port",
                             str(grpc)], cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)
    try:
        ready = "recorded" if command == "visualize" else "Rerun web viewer"
        lines = []
        for line in proc.stdout:
            lines.append(line)
            if ready in line:
                break
        servers = _children(proc.pid)
        assert servers and not _port_free(web) and not _port_free(grpc), "".join(lines)
        proc.send_signal(sig)
        rc = proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    out = "".join(lines) + proc.stdout.read()
    assert rc == 0 and "stopped serving" in out and "Traceback" not in out, out  # serving until stopped: its end
    assert not gone(servers), "the server outlived its command"
    assert _port_free(web) and _port_free(grpc)


def test_view_refuses_a_missing_file(tmp_path, capsys):
    from experiments.__main__ import main

    with pytest.raises(SystemExit) as e:
        main(["view", str(tmp_path / "nope.rrd")])
    assert e.value.code == 2 and "is not a file" in capsys.readouterr().err


def test_viewer_benchmark_reads_the_viewer_state_format():
    """benchmarks/viewer.py's protobuf reader on a hand-encoded GetStateResponse: the active
    recording's timeline entry {1: {1: name}, 3: {1: first, 2: last}, 4: {1: current}}."""
    sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
    try:
        import viewer
    finally:
        sys.path.pop(0)

    def varint(v):
        out = b""
        while True:
            b, v = v & 0x7F, v >> 7
            out += bytes([b | (0x80 if v else 0)])
            if not v:
                return out

    def msg(field, payload: bytes):
        return varint(field << 3 | 2) + varint(len(payload)) + payload

    def num(field, v):
        return varint(field << 3) + varint(v)

    entry = msg(1, msg(1, b"flash_time")) + msg(3, num(1, 5) + num(2, 150_000_000)) + msg(4, num(1, 100_000_000))
    other = msg(1, msg(1, b"trial")) + msg(3, num(2, 7))
    state = msg(1, b"about:recording") + msg(3, msg(2, other) + msg(2, entry))
    assert viewer.cursor(state, "flash_time") == (100_000_000, 150_000_000)
    assert viewer.cursor(state, "trial") == (0, 7)  # proto3 leaves zeros out
    assert viewer.cursor(state, "sim_time") is None
