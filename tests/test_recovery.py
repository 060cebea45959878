"""``python -m experiments recovery``: model recovery across the theories (issue 22, item 6)."""

from __future__ import annotations

import csv
import json
import warnings

import pytest

from experiments.__main__ import main
from experiments.modelfit.data import DataConventionWarning


@pytest.mark.slow
def test_recovery_confusion_matrix(tmp_path, capsys):
    """Each theory's simulated data (with motor noise) is fitted by every theory through a forward
    model without it; the table has one row per (generating, fitted) pair, delta AIC 0 for exactly
    one fitted model per data set, and at this (small, seeded) size each generating model wins on
    its own data. A second run resumes: nothing is simulated or fitted again, the table is the same.
    On a fresh folder it says nothing about an override nobody gave, evaluations "read back" from a
    folder that did not exist, or conventions of its own simulated data (issue 37, the first hour)."""
    args = ["recovery", "--out", str(tmp_path), "--size", "small", "--max-evals", "15", "--image-size", "64"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert main(args) == 0  # with progress: the read-back line is shown only then
    err = capsys.readouterr().err
    assert "override" not in err and "read back" not in err, err
    assert not [w for w in caught if issubclass(w.category, DataConventionWarning)], [str(w.message) for w in caught]
    args.append("--no-progress")
    rows = list(csv.DictReader((tmp_path / "recovery.csv").open()))
    models = ("observer", "population", "paper")
    assert {(r["generating"], r["fitted"]) for r in rows} == {(g, f) for g in models for f in models}
    for g in models:
        mine = [r for r in rows if r["generating"] == g]
        assert sum(float(r["delta_aic"]) == 0 for r in mine) == 1
        assert all(float(r["delta_aic"]) >= 0 for r in mine)
        assert all(int(r["n"]) == 4 * 3 * 2 * 2 for r in mine)  # flashes x times x conditions x reports
        winner = next(r["fitted"] for r in mine if float(r["delta_aic"]) == 0)
        assert winner == g, (g, mine)
        # the data come from noisy saccades; no fitted model reads out those observations
        side = json.loads((tmp_path / g / "data.json").read_text())
        assert side["config"]["endpoint_noise"] == 0.05
        fit = json.loads((tmp_path / g / "fits" / g / "fit.json").read_text())
        assert fit["forward_model"]["config"]["endpoint_noise"] == 0.0
    assert (tmp_path / "recovery.png").stat().st_size > 1000
    before = (tmp_path / "recovery.csv").read_text()
    assert main(args) == 0
    assert (tmp_path / "recovery.csv").read_text() == before


def test_recovery_usage_errors(capsys):
    with pytest.raises(SystemExit) as e:
        main(["recovery", "--reports", "0"])
    assert e.value.code == 2
    assert "--reports" in capsys.readouterr().err
