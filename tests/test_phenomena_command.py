"""``python -m experiments phenomena`` and the observer's timing sweep end to end, on one ``--quick``
scoreboard at 64 px (the commands' machinery, not their numbers): the scoreboard's observations are
simulated once (a module-scoped fixture), then scored again from the cache and swept."""

from __future__ import annotations

import csv

import pytest

from experiments.psychophysics import timing_sweep as ts

ARGS = ["--no-progress", "--image-size", "64", "--bootstrap", "100", "--workers", "1", "--quick"]


@pytest.fixture(scope="module")
def quick_scoreboard(tmp_path_factory):
    """A ``phenomena --quick`` folder at 64 px: its report and its cached observations."""
    from experiments.__main__ import main

    out = tmp_path_factory.mktemp("phenomena")
    assert main(["phenomena", "--out", str(out), *ARGS]) == 0
    return out


@pytest.mark.slow
def test_phenomena_command_writes_the_report(quick_scoreboard):
    """One row per (phenomenon, model) with the published range and its source, the simulated value
    and its bootstrap CI (100 resamples), and verdicts that keep the scoreboard's rules
    (``scoring.check_scoreboard``: role from the calibration table, CI inside the range, diagnostic
    against the baseline); a second run reads the cached observations and gives the same report."""
    from experiments.__main__ import main
    from experiments.psychophysics.phenomena import COLUMNS, ROWS, THEORIES
    from experiments.psychophysics.scoring import check_scoreboard

    with open(quick_scoreboard / "phenomena.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == COLUMNS
    assert {(r["phenomenon"], r["model"]) for r in rows} == {(p, m) for p in ROWS for m in THEORIES}
    assert {r["role"] for r in rows} == {"calibrated", "predicted"}
    assert check_scoreboard(rows) == []
    # the baseline (all mechanisms off) has no compression and no shift before the saccade: the retina alone
    base = {r["phenomenon"]: float(r["simulated"]) for r in rows if r["model"] == "baseline"}
    assert abs(base["shift_dark_presaccadic_deg"]) < 0.5 and abs(base["compression_needs_references"]) < 0.1
    assert len(list(quick_scoreboard.glob("*.png"))) == 3
    before = (quick_scoreboard / "phenomena.csv").read_text()
    assert main(["phenomena", "--out", str(quick_scoreboard), *ARGS]) == 0
    assert (quick_scoreboard / "phenomena.csv").read_text() == before


@pytest.mark.slow
def test_timing_sweep_on_the_scoreboards_observations(quick_scoreboard, tmp_path, capsys):
    """The docs-maintenance command on phenomena --quick's cached observations at 64 px: the prior it
    finds gives the target peak at that size too, the CSV has the sweep's columns, and a timing out of
    the model's range is a usage error."""
    out = tmp_path / "timing.csv"
    assert ts.main(["--phenomena", str(quick_scoreboard), "--timing", "21", "--quick", "--image-size", "64",
                    "--out", str(out)]) == 0
    with open(out, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert tuple(rows[0]) == ts.COLUMNS and len(rows) == 1
    assert abs(float(rows[0]["compression_peak"]) - ts.TARGET_PEAK) <= 0.01
    assert "| timing s.d. (ms) |" in capsys.readouterr().out
    with pytest.raises(SystemExit) as e:
        ts.main(["--phenomena", str(tmp_path), "--timing", "500"])
    assert e.value.code == 2
    assert "a timing s.d. must be 1-150 ms" in capsys.readouterr().err
