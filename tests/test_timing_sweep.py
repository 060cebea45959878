"""The observer's timing sweep (``experiments.psychophysics.timing_sweep``): the prior is set again to its
calibration target at each timing s.d., the committed table is the one the docs show, and its row at the
model's own timing s.d. holds the model's own prior."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from experiments.psychophysics import timing_sweep as ts
from experiments.psychophysics.observer import ObserverParams

ROOT = Path(__file__).resolve().parents[1]


def test_calibrated_prior_finds_the_target_of_a_known_curve():
    """A peak index 1 / (1 + (p / 7)^2) is 0.5 at p = 7 exactly; the bisection lands within its tolerance
    of the target (0.5 +- 0.005 <=> p in [6.86, 7.14]), and says so when the target is not bracketed."""
    calls = []

    def peak(p):
        calls.append(p)
        return 1.0 / (1.0 + (p / 7.0) ** 2)

    p = ts.calibrated_prior(peak)
    assert abs(peak(p) - ts.TARGET_PEAK) <= 0.005 and 6.86 <= p <= 7.14
    assert len(calls) < 20
    with pytest.raises(ValueError, match="not bracketed by prior s.d. 8 and 50"):
        ts.calibrated_prior(peak, lo=8.0)
    with pytest.raises(ValueError, match="not bracketed"):
        ts.calibrated_prior(lambda p: math.nan)


def test_committed_sweep_is_the_docs_table_and_holds_the_models_prior():
    """The docs' table is rendered from ``experiments/data/observer_timing.csv``; every row's prior gives
    the target peak (within 0.01: the prior is kept to 0.1 deg); and at the model's own timing s.d. the
    sweep's prior is the model's: the calibration the scoreboard runs with is the one this finds."""
    rows = ts.read_rows()
    assert ts.markdown_table(rows) in (ROOT / "docs" / "psychophysics" / "theories.md").read_text()
    assert all(abs(float(r["compression_peak"]) - ts.TARGET_PEAK) <= 0.01 for r in rows), rows
    own = ObserverParams()
    mine = [r for r in rows if float(r["temporal_sd_ms"]) == own.temporal_sd_ms]
    assert len(mine) == 1 and float(mine[0]["prior_sd_deg"]) == own.prior_sd_deg


def test_read_rows_refuses_other_columns(tmp_path):
    bad = tmp_path / "x.csv"
    bad.write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="columns must be temporal_sd_ms"):
        ts.read_rows(bad)
