"""Eye-tracker files as labs have them (issue 35): every common EyeLink ASC layout, tables from any
tracker, no saccade across missing data, implausible saccades refused with their probable cause,
and hostile files each given one correct line.

Ground truth: recordings written from simulated traces whose saccades are known (their amplitudes,
directions and onsets: ``eyetracking.synthetic_session``), in each layout."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from experiments.oculomotor import eyetracking as et

TRUE = dict(burst_max_deg_s=600.0, burst_scale_deg=4.0)
SCREEN = et.Screen(1920, 1080, 60.0, 33.75, 57.0)
CM_ONLY = et.Screen(None, None, 60.0, 33.75, 57.0)


@pytest.fixture(scope="module")
def sessions():
    import models

    gen = models.BurstGenerator(**TRUE)
    cache = {}

    def get(rate, n=12, seed=0, n_blinks=1):
        key = (rate, n, seed, n_blinks)
        if key not in cache:
            cache[key] = et.synthetic_session(gen, n_saccades=n, rate_hz=rate, noise_deg=0.02, n_blinks=n_blinks,
                                              seed=seed)
        return cache[key]

    return get


def _matches(rows, s, rate, tol_amp=0.5):
    """Every measured row is one of the simulated saccades (onset, amplitude, direction)."""
    onsets = np.array([a for a, _ in s["saccades"]])
    for r in rows:
        k = int(np.argmin(np.abs(onsets - r["onset_ms"])))
        assert abs(onsets[k] - r["onset_ms"]) < 2 * 1000 / rate + 1
        assert r["amplitude_deg"] == pytest.approx(s["amplitudes"][k], abs=tol_amp)
        assert abs((r["direction_deg"] - s["directions"][k] + 180) % 360 - 180) < 3


# ------------------------------------------------------------------ EyeLink layouts
@pytest.mark.parametrize("rate", [250, 500, 1000, 2000])
def test_asc_rates_and_whole_ms_stamps(tmp_path, sessions, rate):
    """250-2000 Hz; at 2000 Hz ``edf2asc`` (without -ftime) writes whole-ms stamps twice each: read,
    and spread back to 0.5 ms steps."""
    s = sessions(rate)
    whole = rate == 2000
    p = et.write_recording(tmp_path / "r.asc", s["times_ms"], s["x_deg"], s["y_deg"], rate_hz=rate, screen=SCREEN,
                           blinks=s["blinks"], saccades=s["saccades"], whole_ms=whole)
    if whole:
        stamps = [ln.split("\t", 1)[0] for ln in p.read_text().splitlines() if ln[:1].isdigit()]
        assert stamps[0] == stamps[1] != stamps[2]  # written twice
    rec = et.read_recording(p, screen=CM_ONLY)
    assert rec.rate_hz == rate and rec.n_blocks == 1
    assert np.allclose(np.diff(rec.times_ms), 1000 / rate)
    rows = et.main_sequence_rows(rec, et.detect_saccades(rec, "engbert"))
    assert len(rows) >= len(s["amplitudes"]) - 2  # one blink in a fixation may take a neighbour
    _matches(rows, s, rate)


def test_binocular_eye_choice_and_only_that_eyes_events(tmp_path, sessions):
    """A binocular file: the default eye is the one with fewer lost samples (said, with why); each
    eye gets its own events only (the right eye's events are written 6 ms later: a left saccade
    list must not contain them); ``both`` gives each eye."""
    s = sessions(500)
    xr, yr = s["x_deg"] + 0.3, s["y_deg"].copy()
    lost = slice(1000, 1100)  # the left eye loses 200 ms
    xl, yl = s["x_deg"].copy(), s["y_deg"].copy()
    xl[lost] = yl[lost] = np.nan
    right_events = [(a + 6.0, b + 6.0) for a, b in s["saccades"]]
    p = et.write_recording(tmp_path / "b.asc", s["times_ms"], xl, yl, rate_hz=500, screen=SCREEN, eyes="both",
                           right=(xr, yr), saccades={"left": s["saccades"], "right": right_events})
    rec = et.read_recording(p, screen=CM_ONLY)
    assert rec.eye == "right" and "fewer lost samples" in rec.eye_reason
    assert rec.file_saccades_ms == right_events
    left = et.read_recording(p, screen=CM_ONLY, eye="left")
    assert left.file_saccades_ms == s["saccades"] and left.eye_reason == "chosen with --eye"
    both = et.read_recordings(p, screen=CM_ONLY, eye="both")
    assert [r.eye for r in both] == ["left", "right"]
    assert np.nanmedian(both[1].x_deg - both[0].x_deg) == pytest.approx(0.3, abs=0.01)
    for r in both:
        rows = et.main_sequence_rows(r, et.detect_saccades(r, "file"))
        assert len(rows) >= len(s["amplitudes"]) - 2  # no overlapping double events clipping each other
        _matches(rows, s, 500)
    mono = et.write_recording(tmp_path / "m.asc", s["times_ms"], xl, yl, rate_hz=500, screen=SCREEN, eyes="right")
    with pytest.raises(et.RecordingError, match="no left eye in this recording .* give --eye right"):
        et.read_recording(mono, screen=CM_ONLY, eye="left")
    assert et.read_recording(mono, screen=CM_ONLY).eye_reason == "the only eye recorded"


def test_remote_mode_and_display_coords(tmp_path, sessions):
    """Remote mode (``SAMPLES GAZE LEFT HTARGET RATE 500.00`` and the target fields after each
    sample) and an EyeLink II file with ``DISPLAY_COORDS`` and no ``GAZE_COORDS``."""
    s = sessions(500)
    p = et.write_recording(tmp_path / "remote.asc", s["times_ms"], s["x_deg"], s["y_deg"], rate_hz=500, screen=SCREEN,
                           remote=True, coords="display")
    text = p.read_text()
    assert "HTARGET\tRATE" in text and "GAZE_COORDS" not in text and "DISPLAY_COORDS" in text
    rec = et.read_recording(p, screen=CM_ONLY)
    assert rec.rate_hz == 500 and rec.screen.width_px == 1920 and "DISPLAY_COORDS" in rec.notes[0]
    assert "remote" in " ".join(rec.notes)
    np.testing.assert_allclose(rec.x_deg, s["x_deg"], atol=0.01)  # written to 0.1 px
    rows = et.main_sequence_rows(rec, et.detect_saccades(rec, "engbert"))
    assert len(rows) >= len(s["amplitudes"]) - 2


def test_resolution_from_screen_when_the_file_has_none(tmp_path, sessions):
    s = sessions(500)
    p = et.write_recording(tmp_path / "n.asc", s["times_ms"], s["x_deg"], s["y_deg"], rate_hz=500, screen=SCREEN,
                           coords="none")
    with pytest.raises(et.RecordingError, match="no GAZE_COORDS or DISPLAY_COORDS .* all five numbers"):
        et.read_recording(p, screen=CM_ONLY)
    with pytest.raises(et.RecordingError, match="--screen WIDTH_PX HEIGHT_PX WIDTH_CM HEIGHT_CM DISTANCE_CM"):
        et.read_recording(p)
    rec = et.read_recording(p, screen=SCREEN)
    assert "from --screen" in rec.notes[0]
    np.testing.assert_allclose(rec.x_deg, s["x_deg"], atol=0.01)
    g = et.write_recording(tmp_path / "g.asc", s["times_ms"], s["x_deg"], s["y_deg"], rate_hz=500, screen=SCREEN)
    with pytest.raises(et.RecordingError, match="--screen gives 1024 x 768 px but the file's GAZE_COORDS says 1920 x 1080"):
        et.read_recording(g, screen=et.Screen(1024, 768, 60.0, 33.75, 57.0))


def test_blocks_split_the_trace_and_no_saccade_spans_a_gap(tmp_path, sessions):
    """One START/END block per trial: the gaze jumps between blocks (the eye moved while the tracker
    was off). Without the split that jump is a 'saccade' of hundreds of ms; with it, none is measured
    across a gap, and every measured row is one of the simulated saccades."""
    s = sessions(1000, n=16, n_blinks=0)
    t = s["times_ms"]
    ends = [a - 40.0 for a, _ in s["saccades"][3::4]]  # blocks end 40 ms before every 4th saccade ...
    starts = [t[0]] + [e + 300.0 for e in ends]  # ... and the next starts 300 ms later, past it
    blocks = list(zip(starts, ends + [t[-1]]))
    p = et.write_recording(tmp_path / "blocks.asc", t, s["x_deg"], s["y_deg"], rate_hz=1000, screen=SCREEN,
                           blocks=blocks)
    rec = et.read_recording(p, screen=CM_ONLY)
    assert rec.n_blocks == len(blocks)
    rows = et.main_sequence_rows(rec, et.detect_saccades(rec, "engbert"))
    assert all(r["duration_ms"] < 150 for r in rows)
    _matches(rows, s, 1000)
    in_gap = [a for a, _ in s["saccades"] if any(e < a < st for e, st in zip(ends, starts[1:]))]
    assert len(in_gap) == len(ends)
    assert len(rows) >= len(s["amplitudes"]) - len(in_gap) - 4  # lost: those in gaps and next to a block edge
    v = rec.speed()
    gaps = np.flatnonzero(~rec.ok_steps)
    assert len(gaps) == len(blocks) - 1 and all(np.isnan(v[g]) and np.isnan(v[g + 1]) for g in gaps)


def test_table_pauses_and_track_loss_split_the_trace(tmp_path, sessions):
    """A CSV export that pauses (no rows for 2 s) and loses track mid-fixation: no velocity spans
    either, and nothing is measured across them (Engbert detection)."""
    s = sessions(500, n=12, n_blinks=0)
    t = s["times_ms"].copy()
    cut = int(np.searchsorted(t, s["saccades"][6][0] - 30))
    t[cut:] += 2000.0  # a pause just before saccade 7 (its onset stays in the data)
    x, y = s["x_deg"].copy(), s["y_deg"].copy()
    gap = (t > s["saccades"][3][1] + 100) & (t < s["saccades"][3][1] + 160)
    x[gap] = np.nan
    p = et.write_recording(tmp_path / "p.csv", t, x, y, fmt="csv", rate_hz=500, units="deg")
    rec = et.read_recording(p)
    assert rec.n_blocks == 2
    rows = et.main_sequence_rows(rec, et.detect_saccades(rec, "engbert"))
    assert all(r["duration_ms"] < 150 and r["peak_velocity_deg_s"] < 800 for r in rows)
    assert len(rows) >= len(s["amplitudes"]) - 2


@pytest.mark.slow  # imports pymovements
def test_samples_agree_with_pymovements_on_a_plain_file(tmp_path, sessions):
    """On the layout pymovements' own ASC parser reads (monocular, GAZE_COORDS after RECCFG), ours
    gives the same samples and the same degrees (its pix2deg)."""
    import warnings

    import pymovements as pm

    s = sessions(500, n=4)
    p = et.write_recording(tmp_path / "plain.asc", s["times_ms"], s["x_deg"], s["y_deg"], rate_hz=500, screen=SCREEN)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gaze = pm.gaze.from_asc(p, experiment=pm.Experiment(screen_width_cm=60.0, screen_height_cm=33.75,
                                                              distance_cm=57.0, origin="upper left"))
        gaze.pix2deg()
    pos = np.array(gaze.samples["position"].to_list(), float)
    rec = et.read_recording(p, screen=CM_ONLY)
    np.testing.assert_array_equal(gaze.samples["time"].to_numpy(), rec.times_ms)
    np.testing.assert_allclose(rec.x_deg, pos[:, 0], atol=1e-9)
    np.testing.assert_allclose(rec.y_deg, -pos[:, 1], atol=1e-9)


# ------------------------------------------------------------------ plausibility
def test_pixels_in_degree_columns_are_refused_with_the_cause(tmp_path, sessions):
    s = sessions(500)
    px, py = SCREEN.deg2px(s["x_deg"], s["y_deg"])
    p = tmp_path / "wrong.csv"
    p.write_text("time_ms,x_deg,y_deg\n" + "".join(f"{t:.1f},{a:.2f},{b:.2f}\n" for t, a, b in zip(s["times_ms"], px, py)))
    rec = et.read_recording(p)
    rows = et.main_sequence_rows(rec)
    with pytest.raises(et.RecordingError, match="implausible .* pixels in degree columns\\? give --units px"):
        et.check_plausible(rec, rows)


def test_time_in_microseconds_names_the_unit(tmp_path, sessions):
    s = sessions(500, n=4)
    p = tmp_path / "us.csv"
    p.write_text("time_ms,x_deg,y_deg\n" + "".join(f"{t * 1000:.0f},{a:.3f},{b:.3f}\n"
                                                    for t, a, b in zip(s["times_ms"], s["x_deg"], s["y_deg"])))
    with pytest.raises(et.RecordingError, match=r"2000 ms \(0\.5 Hz\).*is the time in us\? give --time-unit us"):
        et.read_recording(p)
    rec = et.read_recording(p, time_unit="us")
    assert rec.rate_hz == pytest.approx(500)


def test_plausible_recording_keeps_its_saccades_and_drops_a_rare_artefact(sessions):
    s = sessions(500)
    rec = et.Recording(et.Path("x.csv"), "csv", s["times_ms"], s["x_deg"], s["y_deg"], 500.0)
    rows = et.main_sequence_rows(rec)
    spike = dict(rows[0], peak_velocity_deg_s=1500.0)
    good, bad = et.check_plausible(rec, rows + [spike])
    assert good == rows and bad == [spike]


# ------------------------------------------------------------------ hostile files: one correct line each
def _rows_text(sep=",", n=60, header="time_ms,x_deg,y_deg", extra=None):
    lines = [header]
    for i in range(n):
        v = [f"{2.0 * i:.1f}", f"{0.01 * i:.3f}", "0.000"] + ([extra] if extra is not None else [])
        lines.append(sep.join(v))
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("name, content, check", [
    ("bom.csv", b"\xef\xbb\xbf" + _rows_text().encode(), "read"),
    ("quoted.csv", _rows_text(header='"time_ms","x_deg","y_deg"').encode(), "read"),
    ("comment.csv", ("# exported 2024-01-01\n# subject 3\n" + _rows_text()).encode(), "read"),
    ("latin1.csv", _rows_text(header="time_ms,x_deg,y_deg,note", extra="caf\xe9").encode("latin-1"), "read"),
    ("utf16.csv", _rows_text().encode("utf-16"), "read"),
    ("utf16le.csv", _rows_text().encode("utf-16-le"), "read"),
    ("tabs.tsv", _rows_text(sep="\t", header="time_ms\tx_deg\ty_deg").encode(), "read"),
    ("trailing.csv", _rows_text(header="time_ms,x_deg,y_deg,").encode(), "read"),
    ("extra.csv", _rows_text(header="time_ms,x_deg,y_deg,pupil").encode(),
     "the header has 4 fields but no row has more than 3"),
    ("text.csv", _rows_text().replace("0.020", "abc", 1).encode(), "line 4: column 'x_deg' holds 'abc', not a number"),
])
def test_hostile_tables(tmp_path, name, content, check):
    p = tmp_path / name
    p.write_bytes(content)
    if check == "read":
        rec = et.read_recording(p)
        assert len(rec.times_ms) == 60 and rec.rate_hz == pytest.approx(500)
        assert rec.x_deg[-1] == pytest.approx(0.59)
    else:
        with pytest.raises(et.RecordingError, match=check):
            et.read_recording(p)


def test_hostile_geometry_and_generator_files(tmp_path):
    with pytest.raises(et.RecordingError, match=r"distance_cm must be a number in \[5, 2000\]; got 1e-300"):
        et.Screen(1920, 1080, 60.0, 33.75, 1e-300)
    with pytest.raises(et.RecordingError, match="whole number of pixels"):
        et.Screen(1920.5, 1080, 60.0, 33.75, 57.0)
    import models

    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(ValueError, match="nested too deeply"):
        models.BurstGenerator.from_file(deep)


def test_asc_hostile_lines(tmp_path, sessions):
    s = sessions(500, n=3)
    p = et.write_recording(tmp_path / "h.asc", s["times_ms"], s["x_deg"], s["y_deg"], rate_hz=500, screen=SCREEN)
    text = p.read_text()
    bad = tmp_path / "bad.asc"
    bad.write_text(text.replace("\tRATE\t 500.00", "", 2).replace("RECCFG CR 500", "RECCFG CR x"))
    with pytest.raises(et.RecordingError, match="has no sampling rate"):
        et.read_recording(bad, screen=CM_ONLY)
    lines = text.splitlines()
    k = next(i for i, ln in enumerate(lines) if ln[:1].isdigit()) + 5
    lines[k] = lines[k].split("\t")[0] + "\t12.0"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(et.RecordingError, match=f"line {k + 1}: a sample with 2 fields"):
        et.read_recording(bad, screen=CM_ONLY)
    dup = [ln for ln in text.splitlines()]
    k = next(i for i, ln in enumerate(dup) if ln[:1].isdigit()) + 5
    dup.insert(k, dup[k])
    bad.write_text("\n".join(dup) + "\n")
    with pytest.raises(et.RecordingError, match="repeats .* at 500 Hz: corrupt or concatenated"):
        et.read_recording(bad, screen=CM_ONLY)


# ------------------------------------------------------------------ the command: eyes, identifiability, folders
def _strict(path):
    import json

    def refuse(name):
        raise AssertionError(f"{path} holds {name}: not strict JSON")

    return json.loads(path.read_text(), parse_constant=refuse)


@pytest.mark.slow
def test_cli_both_eyes_unidentified_fits_and_folder_of_another_recording(tmp_path, sessions, capsys):
    """``--eye both`` reports each eye in its own folder; a fit the saccades cannot identify (9 small
    saccades: burst_lag's CI spans its whole range) exits 3 with one line and writes no
    generator.json but the table and the figure; a run into a folder of another recording removes
    that recording's files first (no old generator.json beside the new table); strict JSON."""
    import models
    from experiments.__main__ import main

    s = sessions(500, n=40, seed=4)
    p = et.write_recording(tmp_path / "bino.asc", s["times_ms"], s["x_deg"], s["y_deg"], rate_hz=500, screen=SCREEN,
                           eyes="both", right=(s["x_deg"] + 0.2, s["y_deg"]), saccades=s["saccades"])
    out = tmp_path / "out"
    assert main(["saccades", "--recording", str(p), "--screen", "60", "33.75", "57", "--eye", "both",
                 "--bootstrap", "0", "--out", str(out)]) == 0
    for eye in ("left", "right"):
        doc = _strict(out / eye / "generator.json")
        assert doc["source"]["eye"] == eye and doc["at_bounds"] == []
        assert _strict(out / eye / "recording.json")["file"] == "bino.asc"
        assert models.BurstGenerator.from_file(out / eye / "generator.json").burst_max_deg_s == pytest.approx(600, rel=0.05)
    assert "left eye (--eye both)" in capsys.readouterr().out

    small = et.synthetic_session(models.BurstGenerator(**TRUE), n_saccades=9, rate_hz=500, seed=2, amplitudes=(2, 4))
    q = et.write_recording(tmp_path / "small.csv", small["times_ms"], small["x_deg"], small["y_deg"], fmt="csv",
                           rate_hz=500, units="deg")
    target = out / "left"  # holds bino.asc's left-eye results
    code = main(["saccades", "--recording", str(q), "--bootstrap", "0", "--out", str(target), "--no-progress"])
    captured = capsys.readouterr()
    assert code == 3
    err = [ln for ln in captured.err.splitlines() if ln.strip()]
    assert len(err) == 1 and "not identified" in err[0] and "no generator.json written" in err[0]
    assert "replaced the results of bino.asc" in captured.out
    assert not (target / "generator.json").exists()  # bino.asc's is gone with the rest
    assert (target / "main_sequence.csv").stat().st_size > 50 and (target / "main_sequence.png").stat().st_size > 1000
    assert _strict(target / "recording.json")["file"] == "small.csv"


# ------------------------------------------------------------------ tables of any tracker
def _export(path, header, rows, sep, comments=()):
    with open(path, "w", encoding="utf-8") as f:
        f.writelines(c + "\n" for c in comments)
        f.write(sep.join(header) + "\n")
        f.writelines(sep.join(r) + "\n" for r in rows)
    return path


def _cell(v, fmt="{:.2f}"):
    return fmt.format(v) if math.isfinite(v) else ""


@pytest.mark.parametrize("layout", ["smi", "tobii", "gazepoint", "judo1000", "gazebase", "columns-long"])
def test_documented_exports_are_read_by_their_preset(tmp_path, sessions, layout):
    """Each documented layout (``oculomotor.tables.PRESETS``), written from a simulated session:
    recognised from its header alone, time unit and gaze unit from the preset, the eye chosen, the
    saccades found where they were simulated."""
    s = sessions(500, n=10)
    t, x, y = s["times_ms"], s["x_deg"], s["y_deg"]
    px, py = SCREEN.deg2px(x, y)
    p = tmp_path / f"{layout}.txt"
    kw = {"screen": SCREEN}
    if layout == "smi":  # BeGaze: '##' header, Time in us, only SMP rows are samples, right eye only
        rows = [[f"{ti * 1000:.0f}", "SMP", "1", _cell(a), _cell(b)] for ti, a, b in zip(t, px, py)]
        rows.insert(40, [f"{t[40] * 1000 + 1:.0f}", "MSG", "1", "# Message: trial 1", ""])
        _export(p, ["Time", "Type", "Trial", "R POR X [px]", "R POR Y [px]"], rows, "\t",
                ["## [BeGaze]", "## Sample Rate:\t500"])
        eye = "right"
    elif layout == "tobii":  # Pro Lab: tab-separated, µs, both eyes, decimal comma
        rows = [[f"{ti * 1000:.0f}", _cell(a).replace(".", ","), _cell(b).replace(".", ","),
                 _cell(a + 4).replace(".", ","), _cell(b).replace(".", ",")] for ti, a, b in zip(t, px, py)]
        _export(p, ["Recording timestamp", "Gaze point left X", "Gaze point left Y", "Gaze point right X",
                    "Gaze point right Y"], rows, "\t")
        eye = "left"
    elif layout == "gazepoint":  # Open Gaze API: TIME in s, POG as a fraction of the screen
        rows = [[f"{ti / 1000:.4f}", _cell(a / 1920, "{:.6f}"), _cell(b / 1080, "{:.6f}")] for ti, a, b in zip(t, px, py)]
        _export(p, ["TIME", "LPOGX", "LPOGY"], rows, ",")
        eye = "left"
    elif layout == "judo1000":
        rows = [[f"{ti:.1f}", _cell(a), _cell(b), _cell(a), _cell(b)] for ti, a, b in zip(t, px, py)]
        _export(p, ["time", "x_left", "y_left", "x_right", "y_right"], rows, "\t")
        eye = "left"
    elif layout == "gazebase":
        rows = [[f"{ti:.1f}", _cell(a, "{:.4f}"), _cell(b, "{:.4f}"), "0"] for ti, a, b in zip(t, x, y)]
        _export(p, ["n", "x", "y", "val"], rows, ",")
        eye = "unnamed"
        kw = {}
    else:  # a long table: one row per eye and sample, named with --columns
        rows = []
        for ti, a, b in zip(t, px, py):
            rows += [[f"{ti:.1f}", "L", _cell(a), _cell(b)], [f"{ti:.1f}", "R", _cell(a + 3), _cell(b)]]
        _export(p, ["ts", "eye", "gx", "gy"], rows, ",")
        from experiments.oculomotor.tables import parse_columns

        kw["columns"] = parse_columns("time=ts,x=gx,y=gy,eye=eye")
        kw["units"] = "px"
        eye = "left"
    rec = et.read_recording(p, **kw)
    assert rec.eye == eye and rec.rate_hz == pytest.approx(500, rel=1e-3)
    np.testing.assert_allclose(rec.x_deg, x, atol=0.01, equal_nan=True)
    np.testing.assert_allclose(rec.y_deg, y, atol=0.01, equal_nan=True)
    rows_ = et.main_sequence_rows(rec, et.detect_saccades(rec, "engbert"))
    assert len(rows_) >= len(s["amplitudes"]) - 2
    _matches(rows_, s, 500)


def test_columns_option_errors(tmp_path):
    from experiments.oculomotor.tables import TableError, parse_columns

    with pytest.raises(TableError, match="needs y=NAME too"):
        parse_columns("time=t,x=a")
    with pytest.raises(TableError, match="time=NAME,x=NAME,y=NAME"):
        parse_columns("time=t,x=a,y=b,z=c")
    p = _export(tmp_path / "c.csv", ["T", "X", "Y"], [[str(i), "1", "2"] for i in range(20)], ",")
    with pytest.raises(et.RecordingError, match="no column 't' in the header \\(did you mean 'T'\\?\\)"):
        et.read_recording(p, columns=parse_columns("time=t,x=X,y=Y"), units="deg")
    with pytest.raises(et.RecordingError, match="give --units px or --units deg"):
        et.read_recording(p, columns=parse_columns("time=T,x=X,y=Y"))


def test_gaze_as_a_fraction_of_the_screen_is_never_read_as_degrees(tmp_path):
    """Gazepoint's POG is a share of the screen, read through its pixels: with --units deg it was
    multiplied by the resolution and taken for degrees (without --screen: an AttributeError); it is
    refused. Read as it is, the centre pixel's half-pixel offset is atan(0.5 px / (57 cm * 32 px/cm))."""
    rows = [[f"{i / 500:.4f}", "0.5", "0.5"] for i in range(40)]
    p = _export(tmp_path / "gp.csv", ["TIME", "LPOGX", "LPOGY"], rows, ",")
    for screen in (None, SCREEN):
        with pytest.raises(et.RecordingError, match="a fraction of the screen.*cannot be in degrees"):
            et.read_recording(p, preset="gazepoint", units="deg", screen=screen)
    rec = et.read_recording(p, preset="gazepoint", screen=SCREEN)
    half_px = math.degrees(math.atan2(0.5, 57.0 * 1920 / 60.0))  # 32 px/cm on both axes (1080 / 33.75)
    np.testing.assert_allclose(rec.x_deg, half_px, rtol=1e-12)
    np.testing.assert_allclose(rec.y_deg, -half_px, rtol=1e-12)  # y up


def test_a_screen_without_its_resolution_says_so():
    """``Screen(None, None, ...)`` takes its pixels from an ASC file; used for pixels before that, it
    says what is missing (it was a TypeError on None)."""
    for use in (lambda: CM_ONLY.px2deg(0.0, 0.0), lambda: CM_ONLY.deg2px(0.0, 0.0), CM_ONLY.px_per_cm):
        with pytest.raises(et.RecordingError, match="no resolution yet"):
            use()
    assert CM_ONLY.with_resolution(1920, 1080).px_per_cm() == (32.0, 1080 / 33.75)


def test_a_unit_in_brackets_after_a_preset_name_sets_the_time_unit():
    """Newer Tobii Pro Lab exports write the unit into the name (``Recording timestamp [ms]``): the
    preset still matches, and the bracket's unit wins over the preset's default (µs)."""
    from experiments.oculomotor.tables import read_table

    text = "Recording timestamp [ms]\tGaze point left X\tGaze point left Y\n" + "".join(
        f"{2 * i}\t{i}\t{i}\n" for i in range(30))
    tab = read_table(text, "t.tsv")
    assert tab.columns.source == "Tobii Pro Lab" and tab.time_unit == "ms" and list(tab.x) == ["left"]


@pytest.mark.parametrize("argv, message", [
    (["--columns", "time=t,x=a"], "argument --columns: --columns needs y=NAME too"),
    (["--screen", "60", "33.75", "1e-300"], r"argument --screen: screen distance_cm must be a number in \[5, 2000\]"),
    (["--screen", "1920.5", "1080", "60", "33.75", "57"], "WIDTH_PX HEIGHT_PX must be whole numbers"),
    (["--eye", "middle"], "argument --eye: invalid choice"),
    (["--time-unit", "min"], "argument --time-unit: invalid choice"),
])
def test_cli_option_errors_are_one_line(tmp_path, capsys, argv, message):
    from experiments.__main__ import main

    p = tmp_path / "r.csv"
    p.write_text(_rows_text())
    with pytest.raises(SystemExit) as e:
        main(["saccades", "--recording", str(p), "--out", str(tmp_path / "o"), *argv])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert re.search(message, err[-1]) and not (tmp_path / "o").exists()


def test_cli_deeply_nested_generator_file_is_a_usage_error(tmp_path, capsys):
    from experiments.__main__ import build_parser

    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(SystemExit) as e:
        build_parser().parse_args(["run", "--generator", str(deep)])
    assert e.value.code == 2 and "nested too deeply" in capsys.readouterr().err


@pytest.mark.slow  # runs the head's legacy saccades
def test_model_run_into_a_recordings_folder_replaces_it_whole(tmp_path, capsys):
    import json

    from experiments.__main__ import main

    out = tmp_path / "o"
    out.mkdir()
    (out / "recording.json").write_text(json.dumps({"file": "subject1.asc"}))
    (out / "generator.json").write_text("{}")
    (out / "main_sequence.csv").write_text("saccade,onset_ms\n1,2\n")
    assert main(["saccades", "--out", str(out), "--model", "legacy", "--no-progress"]) == 0
    assert not (out / "recording.json").exists() and not (out / "generator.json").exists()
    assert (out / "main_sequence.csv").read_text().startswith("model,")
    assert "replaced the results of a recording" in capsys.readouterr().out


def test_eye_option_on_a_table_without_eyes(tmp_path):
    p = tmp_path / "r.csv"
    p.write_text(_rows_text())
    with pytest.raises(et.RecordingError, match="do not say which eye they are; leave out --eye"):
        et.read_recording(p, eye="left")
    assert et.read_recording(p).eye_reason == "one gaze column"
