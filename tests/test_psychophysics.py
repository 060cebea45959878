"""Tests of the flash-localization psychophysics (experiments.psychophysics, python -m experiments run)."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

import conformal as C
from experiments.psychophysics import (
    ROW_COLUMNS, Design, RemapTimeCourse, TrialConfig, TrialRunner, activity_centroid, compression_index,
    read_table, run_trials, sampling_error, summary,
)

OFFSETS = ((-8.0, 3.0), (8.0, -3.0), (-4.0, -6.0), (4.0, 6.0), (-12.0, 3.0))
TIMES = (-150, -100, -50, -25, -10, 0, 25, 50, 100, 150)


# ---------------------------------------------------------------- pure parts
def test_timecourse_shape_and_validation():
    tc = RemapTimeCourse(peak_time_ms=-10, rise_ms=25, decay_ms=30, peak_gain=math.log(2))
    t = np.arange(-300, 301)
    g = tc.gain(t)
    assert t[np.argmax(g)] == -10 and math.isclose(g.max(), math.log(2))
    # one s.d. before / after the peak: exp(-1/2) of the peak on each flank
    assert math.isclose(tc.gain(-35.0), math.log(2) * math.exp(-0.5), rel_tol=1e-12)
    assert math.isclose(tc.gain(20.0), math.log(2) * math.exp(-0.5), rel_tol=1e-12)
    assert tc.gain(-150.0) < 1e-6 and tc.gain(150.0) < 1e-6
    assert math.isclose(tc.compression(-10.0), 0.5)
    for bad in (dict(rise_ms=0), dict(decay_ms=-1), dict(peak_gain=-0.1), dict(peak_time_ms=float("nan"))):
        with pytest.raises(ValueError):
            RemapTimeCourse(**bad)


def test_design_expansion():
    d = Design(amplitudes_deg=(12, 20), flash_offsets_deg=OFFSETS[:2], flash_times_ms=(-50, 0, 50), repetitions=2, seed=7)
    trials = d.trials()
    assert len(trials) == d.n_trials == 2 * 2 * 3 * 2
    assert [t.trial_id for t in trials] == list(range(24))
    assert len({(t.repetition, t.amplitude_deg, t.flash_dx_deg, t.flash_time_ms) for t in trials}) == 24
    assert trials[5].seed == 12 and trials[0].target_deg == (6.0, 0.0) and trials[0].fixation_deg == (-6.0, 0.0)
    assert trials == d.trials()
    for bad in (dict(amplitudes_deg=()), dict(amplitudes_deg=(-5,)), dict(flash_times_ms=(0.5,)), dict(repetitions=0),
                dict(flash_offsets_deg=((100.0, 0.0),))):
        with pytest.raises(ValueError):
            Design(**bad)


def test_centroid_of_a_blob_on_the_retina():
    """The read-out of an analytic Gaussian blob sampled by the retina is near the blob's centre."""
    grid = C.RetinaGrid.from_field_of_view(0.7, math.tan(math.radians(2)), 32)
    size, ppu = 256, 128 / 0.7
    zpix = C.pixel_points((size, size), ppu)
    retina = C.Retina(grid, (size, size, 1), ppu)
    for z0 in (0.2 + 0.1j, -0.3 - 0.25j, 0.02 - 0.01j):
        img = np.exp(-np.abs(zpix - z0) ** 2 / (2 * 0.03**2))[..., None]
        s = retina.sample(img)
        c = activity_centroid(s.periphery, s.fovea, grid, mask=s.mask, fovea_mask=s.fovea_mask)
        ecc = math.degrees(math.atan(abs(z0)))
        err = math.degrees(math.atan(abs(c - z0) / (1 + abs(z0) ** 2)))  # roughly the angle
        assert err < 0.1 * ecc + 0.3, (z0, c)
    assert np.isnan(activity_centroid(np.zeros((grid.M, grid.N)), np.zeros(grid.n_fovea), grid).real)


# ---------------------------------------------------------------- the pipeline
@pytest.fixture(scope="module")
def tables():
    design = Design(amplitudes_deg=(20.0,), flash_offsets_deg=OFFSETS, flash_times_ms=TIMES)
    out = {}
    # "remap"/"none" read out through the true eye orientation, isolating the remapping; "signal"
    # reads out through the eye-position signal with no remapping, isolating that signal
    for name, gain, eye in (("remap", math.log(2), "true"), ("none", 0.0, "true"), ("signal", 0.0, "signal")):
        runner = TrialRunner(TrialConfig(model="paper", timecourse=RemapTimeCourse(peak_gain=gain), eye_position=eye))
        rows = [runner.run(t) for t in design.trials()]
        runner.close()
        out[name] = {c: np.array([r[c] for r in rows], float) for c in ROW_COLUMNS}
    return out


@pytest.mark.slow
def test_gain_zero_is_veridical_up_to_sampling_error(tables):
    t = tables["none"]
    err = sampling_error(t)
    print("sampling error (gain 0):", err)
    assert abs(err["bias_x_deg"]) < 0.75 and abs(err["bias_y_deg"]) < 0.75  # measured 0.20, 0.49
    assert err["rms_x_deg"] < 1.5 and err["rms_y_deg"] < 1.5 and err["max_deg"] < 3.5
    # the closed form with g = 0 is the true position (geometry round trip, independent of the retina)
    assert np.allclose(t["closed_form_x_deg"], t["true_x_deg"], atol=1e-6)
    assert np.allclose(t["closed_form_y_deg"], t["true_y_deg"], atol=1e-6)
    assert np.allclose(t["true_x_deg"], 10 + t["flash_dx_deg"], atol=1e-3)  # the head sways ~1e-4 deg
    assert np.allclose(t["target_x_deg"], 10.0, atol=1e-3) and np.allclose(t["target_y_deg"], 0.0, atol=1e-3)


@pytest.mark.slow
def test_eye_position_signal_shifts_flashes_along_then_against_the_saccade(tables):
    """With no remapping, the eye-position signal alone shifts perisaccadic flashes uniformly: in
    the saccade's direction for flashes shortly before and at onset (the signal already moves
    while the eye has not), against it for flashes after the saccade (the signal lags the eye),
    and not at all far from the saccade -- the biphasic pattern of flashes in darkness (Honda
    1991, Vision Res 31:1915, Fig. 2; Dassonville et al. 1992, Vis Neurosci 9:261; Matin & Pearce
    1965). Measured relative to the true-eye read-out of the same frames (``none``), so the
    retina's sampling error cancels."""
    s, n = tables["signal"], tables["none"]
    shift = s["perceived_x_deg"] - n["perceived_x_deg"]  # the saccade goes right (+x), 20 deg
    t = s["flash_time_ms"]
    for lo, hi, sign in ((-50, 0, +1), (50, 100, -1)):
        sel = (t >= lo) & (t <= hi)
        assert np.all(sign * shift[sel] > 0.5), (lo, hi, shift[sel])
    # uniform: the same shift for every flash position at a given time (within 0.5 deg)
    for tt in (-25, 50):
        assert np.ptp(shift[t == tt]) < 0.5, shift[t == tt]
    # largest (in absolute value) after the saccade, where the eye has moved and the signal has not
    assert abs(shift[t == 50].mean()) > abs(shift[t == -150].mean())
    assert abs(shift[t == -150].mean()) < 0.5


@pytest.mark.slow
def test_errors_point_towards_the_target_near_onset(tables):
    r, n = tables["remap"], tables["none"]
    near = np.abs(r["flash_time_ms"] - (-10)) <= 10
    dx = r["flash_dx_deg"]
    # relative to the gain-0 read-out of the same frames: the effect of remapping alone
    tx = np.sign(-dx) * (r["perceived_x_deg"] - n["perceived_x_deg"])
    ty = np.sign(-r["flash_dy_deg"]) * (r["perceived_y_deg"] - n["perceived_y_deg"])
    for side in (dx < 0, dx > 0):  # flashes before and beyond the target along the saccade
        assert np.all(tx[near & side] > 0.5), tx[near & side]
    assert np.all(ty[near] > 0.3), ty[near]  # orthogonal to the saccade too
    # absolute errors also point towards the target, on average per side and orthogonally
    for side in (dx < 0, dx > 0):
        assert r["error_toward_x_deg"][near & side].mean() > 1.0
    assert r["error_toward_y_deg"][near].mean() > 0.5
    # the decoded compression follows the closed form within the sampling error
    d = np.hypot(r["perceived_x_deg"] - r["closed_form_x_deg"], r["perceived_y_deg"] - r["closed_form_y_deg"])
    assert np.max(d[near]) < 3.5


@pytest.mark.slow
def test_compression_peaks_near_onset_and_vanishes_far_from_it(tables):
    r, n = tables["remap"], tables["none"]
    times, ci = compression_index(r)[20.0]
    assert abs(times[np.argmax(ci)]) <= 25 and ci.max() > 0.3
    _, ci0 = compression_index(n)[20.0]
    far = np.abs(times) >= 150
    assert np.allclose(ci[far], ci0[far], atol=1e-3)
    f = np.abs(r["flash_time_ms"]) >= 150
    assert np.allclose(r["perceived_x_deg"][f], n["perceived_x_deg"][f], atol=1e-3)
    assert np.allclose(r["perceived_y_deg"][f], n["perceived_y_deg"][f], atol=1e-3)
    row = summary(r)[0]
    assert abs(row["peak_time_ms"]) <= 25 and 20 < row["fwhm_ms"] < 150
    # the summary's mean error direction (|t| <= 50 ms) points at the target along and across
    near = np.abs(r["flash_time_ms"]) <= 50
    assert row["mean_toward_x_deg"] == pytest.approx(r["error_toward_x_deg"][near].mean())
    assert row["mean_toward_x_deg"] > 0.5 and row["mean_toward_y_deg"] > 0.3
    assert summary(n)[0]["mean_toward_x_deg"] < row["mean_toward_x_deg"] / 3  # gain 0: little left


# ---------------------------------------------------------------- runner
SMALL = Design(amplitudes_deg=(16.0,), flash_offsets_deg=OFFSETS[:2], flash_times_ms=(-50, 0, 50, 100), seed=3)
CFG = TrialConfig(image_size=128)


def test_interrupted_run_resumes_to_the_same_table(tmp_path):
    full = run_trials(SMALL, CFG, tmp_path / "full", workers=1, progress=False)
    part_dir = tmp_path / "part"
    run_trials(SMALL, CFG, part_dir, workers=1, progress=False, limit=3, batch_size=1)
    with (part_dir / "trials.csv").open("a") as fh:
        fh.write("5,0,8,16,0,8.0,-3")  # a row torn by the interruption
    with pytest.raises(ValueError, match="line 5"):  # a finished table may not hold one
        read_table(part_dir / "trials.csv")
    with pytest.warns(RuntimeWarning, match="torn"):
        assert len(read_table(part_dir / "trials.csv", partial=True)["trial_id"]) == 3
    seen = []
    run_trials(SMALL, CFG, part_dir, workers=1, progress=False, on_row=lambda r: seen.append(int(r["trial_id"])))
    assert sorted(seen) == [i for i in range(SMALL.n_trials) if i >= 3]  # nothing redone
    assert (part_dir / "trials.csv").read_bytes() == full.read_bytes()
    import pyarrow.parquet as pq

    t = pq.read_table(part_dir / "trials.parquet")
    assert t.num_rows == SMALL.n_trials and set(ROW_COLUMNS) <= set(t.column_names)
    csv = read_table(part_dir / "trials.csv")
    order = np.argsort(t.column("trial_id").to_numpy())
    for c in ROW_COLUMNS:  # the same values as the CSV, not only the same shape
        assert np.allclose(t.column(c).to_numpy()[order].astype(float), np.asarray(csv[c], float), equal_nan=True), c
    with pytest.raises(ValueError, match="different design"):
        run_trials(Design(amplitudes_deg=(12.0,)), CFG, part_dir, workers=1, progress=False)


@pytest.mark.slow  # starts a pool of two processes (~5 s)
def test_a_short_run_stays_in_this_process_unless_workers_are_asked_for(tmp_path, monkeypatch):
    """``run_trials(workers=None)`` (``run``'s default) runs a design of at most ``SMALL_RUN_TRIALS``
    trials here, with no pool (the same table as ``workers=1``); an explicit ``workers=2`` still starts
    one. ``run --help`` states the same number."""
    from experiments.cli.options import AUTO_WORKERS_HELP
    from experiments.psychophysics import runner

    assert SMALL.n_trials <= runner.SMALL_RUN_TRIALS and f" {runner.SMALL_RUN_TRIALS} trials" in AUTO_WORKERS_HELP
    pools = []
    real = runner._make_pool
    monkeypatch.setattr(runner, "_make_pool", lambda *a: pools.append(a) or real(*a))
    auto = run_trials(SMALL, CFG, tmp_path / "auto", workers=None, progress=False)
    assert pools == []
    one = run_trials(SMALL, CFG, tmp_path / "one", workers=1, progress=False)
    assert auto.read_bytes() == one.read_bytes()
    run_trials(SMALL, CFG, tmp_path / "two", workers=2, progress=False, batch_size=1)
    assert len(pools) == 1


def test_progress_bar_counts_the_trials(tmp_path, capsys):
    d = Design(amplitudes_deg=(16.0,), flash_offsets_deg=OFFSETS[:2], flash_times_ms=(-50, 0), seed=3)
    run_trials(d, CFG, tmp_path / "bar", workers=1, progress=True)
    err = capsys.readouterr().err
    assert "flash trials" in err and f"{d.n_trials}/{d.n_trials}" in err


_KILL_SCRIPT = """
import sys
from experiments.psychophysics import Design, TrialConfig, run_trials
from experiments.psychophysics.design import FIG11_OFFSETS_DEG
if __name__ == "__main__":  # spawn workers re-import this file
    d = Design(amplitudes_deg=(16.0,), flash_offsets_deg=FIG11_OFFSETS_DEG[:6],
               flash_times_ms=(-150, -100, -50, 0, 50, 100, 150, 200), seed=3)
    run_trials(d, TrialConfig(image_size=128), sys.argv[1], workers=int(sys.argv[2]), progress=False, batch_size=1)
"""


@pytest.mark.slow
def test_killed_parallel_run_resumes(tmp_path):
    """SIGKILL a 2-process run mid-way; the resumed table equals an uninterrupted in-process run."""
    script = tmp_path / "job.py"
    script.write_text(_KILL_SCRIPT)
    out = tmp_path / "killed"
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    proc = subprocess.Popen([sys.executable, str(script), str(out), "2"], env=env, start_new_session=True)
    csv_path = out / "trials.csv"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if csv_path.exists() and len(csv_path.read_text().splitlines()) >= 3:  # header + 2 rows
            break
        time.sleep(0.005)
    killed = proc.poll() is None
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # the kill may tear the last row
        n_before = len(read_table(csv_path, partial=True)["trial_id"])
    subprocess.run([sys.executable, str(script), str(out), "2"], env=env, check=True)
    ref = tmp_path / "ref"
    subprocess.run([sys.executable, str(script), str(ref), "1"], env=env, check=True)
    assert csv_path.read_bytes() == (ref / "trials.csv").read_bytes()
    assert killed and 0 < n_before < 48  # the kill did interrupt the run (48 trials in all)


# ---------------------------------------------------------------- command line
def test_cli_help_and_bad_options(capsys):
    from experiments.__main__ import build_parser, main

    parser = build_parser()
    with pytest.raises(SystemExit):
        parser.parse_args(["run", "--help"])
    text = capsys.readouterr().out
    for opt in ("--out", "--quick", "--amplitudes", "--flash-times", "--peak-time-ms", "--rise-ms", "--decay-ms",
                "--peak-gain", "--workers", "--image-size"):
        assert opt in text
    for bad in (["--amplitudes", "abc"], ["--flash-times", "5:1:1"], ["--workers", "0"], ["--rise-ms", "-3"],
                ["--positions", "nope"], ["--formats", "gif"], ["--amplitudes", "90"]):
        with pytest.raises(SystemExit) as e:
            main(["run", "--out", "unused", *bad])
        assert e.value.code == 2
        assert "error" in capsys.readouterr().err


@pytest.mark.slow
def test_cli_small_study_writes_outputs(tmp_path):
    from experiments.__main__ import main

    out = tmp_path / "res"
    code = main(["run", "--out", str(out), "--amplitudes", "20", "--positions", "morrone", "--flash-times=-100,0,150",
                 "--workers", "1", "--image-size", "128", "--no-progress", "--formats", "png,svg"])
    assert code == 0
    t = read_table(out / "trials.csv")
    for c in ("saccade_amplitude_deg", "flash_time_ms", "true_x_deg", "true_y_deg", "perceived_x_deg",
              "perceived_y_deg", "target_x_deg", "target_y_deg"):
        assert len(t[c]) == 24
    for name in ("fig11.png", "perceived_vs_time.png", "compression_vs_time.png", "summary.txt", "study.rrd",
                 "trials.parquet"):
        assert (out / name).stat().st_size > 0
    for name in ("fig11", "perceived_vs_time", "compression_vs_time"):
        assert (out / f"{name}.svg").read_text().lstrip().startswith(("<?xml", "<svg"))
    from rerun.chunk import RrdReader

    paths = RrdReader(str(out / "study.rrd")).store().schema().entity_paths()
    assert any("study/perceived" in p for p in paths) and any("flash/perceived" in p for p in paths)
    # one frame per flash time on the flash_time timeline (ms re saccade onset), holding every trial's
    # true and perceived position of that time; and one per trial on the trial timeline
    from test_recording_readable import chunks  # tests/ is on sys.path under pytest's default import mode

    rec = chunks(out / "study.rrd")
    for name in ("/study/true", "/study/perceived"):
        by_time = sorted((r["flash_time"], len(r["cols"]["Points2D:positions"])) for r in rec[name] if "flash_time" in r)
        assert by_time == [(-100_000_000, 8), (0, 8), (150_000_000, 8)]  # ns; 24 trials / 3 times
        assert sorted(r["trial"] for r in rec[name] if "trial" in r) == sorted(t["trial_id"].tolist())


@pytest.mark.slow
def test_quick_study_through_the_command_line(tmp_path):
    """``run --quick``: the reduced design (one 20 deg saccade, 8 dots, 7 times) writes every output,
    and its summary shows compression near onset."""
    from experiments.__main__ import main

    out = tmp_path / "quick"
    assert main(["run", "--quick", "--out", str(out), "--no-progress"]) == 0
    t = read_table(out / "trials.csv")
    assert len(t["trial_id"]) == 8 * 7 and set(np.asarray(t["saccade_amplitude_deg"], float)) == {20.0}
    for name in ("trials.parquet", "summary.txt", "summary.csv", "study.rrd", "run.json", "fig11.png", "fig11.svg",
                 "perceived_vs_time.png", "compression_vs_time.png"):
        assert (out / name).stat().st_size > 0, name
    row = summary(t)[0]
    assert row["peak_compression"] > 0.3 and abs(row["peak_time_ms"]) <= 25


def test_displacement_report_noise_is_independent_of_landing_scatter():
    """The displacement report's noise has its own stream: ``Head.reset(seed)`` draws the landing scatter
    from ``default_rng(seed)``; a report drawn from that same stream correlated with the landing error at
    r = -0.97 and shrank every theory's displacement threshold. Over 2000 trial seeds the two streams'
    first normals must be uncorrelated (|r| < 0.1, about 4.5 standard errors)."""
    from experiments.psychophysics.trial import report_noise

    seeds = range(2000)
    head = np.array([np.random.default_rng(s).normal() for s in seeds])
    report = np.array([report_noise(s, 1.0) for s in seeds])
    assert report_noise(3, 0.0) == 0.0
    assert abs(np.corrcoef(head, report)[0, 1]) < 0.1
    src = Path(__file__).resolve().parents[1] / "experiments/psychophysics/trial.py"
    assert ".default_rng(trial.seed)" not in src.read_text()  # no draw shares the head's stream
