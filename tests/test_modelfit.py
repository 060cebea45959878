"""experiments.modelfit: the data format, parameter and model recovery, the Ray backend, resume.

Recovery is the ground truth here: data simulated from known parameters (with report noise) must
be fitted back within the fit's own 95 % intervals, and a comparison on data from one model must
prefer that model.
"""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from experiments.modelfit import DataFormatError, read_data, simulate_data
from experiments.modelfit.fitting import compare, fit
from experiments.psychophysics import Design, TrialConfig

OFFSETS = ((-8.0, 3.0), (8.0, -3.0), (-4.0, -6.0), (4.0, 6.0), (-12.0, 3.0), (2.0, -4.0))
DESIGN = Design(amplitudes_deg=(20.0,), flash_offsets_deg=OFFSETS, flash_times_ms=(-150, -100, -50, -25, 0, 25, 50, 100))
#: Half the flash positions, twice the reports: the same number of rows for half the trials to observe.
RECOVERY = Design(amplitudes_deg=(20.0,), flash_offsets_deg=OFFSETS[::2], flash_times_ms=DESIGN.flash_times_ms)
TRUTH = {"feedback_gain": 3.5, "eps_sigma_ms": 40.0, "eps_delay_ms": 65.0, "noise_x_deg": 0.7, "noise_y_deg": 0.6}


def _write(path, header, rows):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows(rows)
    return path


GOOD = ["saccade_amplitude_deg", "flash_time_ms", "true_x_deg", "true_y_deg", "perceived_x_deg", "perceived_y_deg"]


def test_fit_defaults_are_the_models_own_constants():
    """A fit's start and the truth ``simulate``, ``recovery`` and ``crossval`` generate data with
    (``Parameter.default``) are the constants the scoreboard runs with: put into a default config
    they change nothing. (They had drifted: ``temporal_sd_ms`` 40 here, 21 in ``ObserverParams``.)"""
    from experiments.modelfit.likelihood import FIT_MODELS

    for name, m in FIT_MODELS.items():
        base = TrialConfig(**m.config)
        values = {p.name: p.default for p in m.parameters if not p.name.startswith("noise")}
        assert m.trial_config(base, values) == base, name


@pytest.mark.parametrize("header,row,match", [
    (GOOD[:-1], [20, 0, 2, 3, 4], "missing column"),
    (GOOD, [20, 0, 2, 3, "x", 1], "perceived_x_deg.*not numbers"),
    (GOOD, [0, 0, 2, 3, 4, 1], "saccade_amplitude_deg"),
    (GOOD, [60, 0, 2, 3, 4, 1], "saccade_amplitude_deg"),
    (GOOD, [20, 0.5, 2, 3, 4, 1], "flash_time_ms"),
    (GOOD, [20, 0, 200, 3, 4, 1], "true_x_deg"),
    (GOOD, [20, 0, 2, 3, "nan", 1], "perceived_x_deg"),
    (GOOD + ["condition"], [20, 0, 2, 3, 4, 1, "dusk"], "condition"),
    (GOOD + ["n"], [20, 0, 2, 3, 4, 1, 0], "column n"),
    (GOOD + ["n", "sd_x_deg"], [20, 0, 2, 3, 4, 1, 1, 0.5], "sd_x_deg"),
])
def test_data_errors_name_the_column_and_row(tmp_path, header, row, match):
    p = _write(tmp_path / "d.csv", header, [row])
    with pytest.raises(DataFormatError, match=match):
        read_data(p)


def test_data_reads_csv_and_parquet_alike(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    rows = [[20, -50, 12, 3, 11.5, 2.5, "dark", 5, 0.7, 0.6], [16, 0, 4, -3, 5, -2, "references", 1, "", ""]]
    header = GOOD + ["condition", "n", "sd_x_deg", "sd_y_deg"]
    a = read_data(_write(tmp_path / "d.csv", header, rows))
    cols = {h: [r[i] if r[i] != "" else None for r in rows] for i, h in enumerate(header)}
    pq.write_table(pa.table(cols), tmp_path / "d.parquet")
    b = read_data(tmp_path / "d.parquet")
    assert a.n_observations == 6 and list(a.condition) == ["dark", "references"]
    for f in ("amplitude_deg", "flash_time_ms", "true_deg", "perceived_deg", "n"):
        assert np.array_equal(getattr(a, f), getattr(b, f))
    assert np.isnan(a.sd_deg[1]).all() and a.sd_deg[0] == pytest.approx([0.7, 0.6])
    with pytest.raises(DataFormatError, match="no such file"):
        read_data(tmp_path / "nope.csv")
    (tmp_path / "bin.csv").write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(DataFormatError):
        read_data(tmp_path / "bin.csv")


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    path = tmp_path_factory.mktemp("sim") / "sim.csv"
    simulate_data("mechanistic", TRUTH, RECOVERY, reports=8, seed=1, out_csv=path)
    return read_data(path)


@pytest.mark.slow
def test_parameters_and_model_are_recovered(simulated, tmp_path):
    """Data from the mechanistic model at known parameters: the fit recovers every parameter within
    its 95 % interval, and a comparison with the paper model and the nested no-remap variant prefers
    the generating model by AIC and rejects the restriction by the likelihood-ratio test."""
    rows = compare(simulated, ["mechanistic", "mechanistic/no_command_remap", "paper"], tmp_path, max_evals=120,
                   workers=1)
    assert rows[0]["model"] == "mechanistic", rows
    fitted = json.loads((tmp_path / "mechanistic" / "fit.json").read_text())
    assert fitted["hessian_ok"]
    for k, v in TRUTH.items():
        lo, hi = fitted["ci"][k]
        assert lo <= v <= hi, (k, v, fitted["parameters"][k], (lo, hi))
        assert hi - lo < 0.3 * abs(v) + 0.2  # informative intervals, not the whole range
    for key in ("model", "parameters", "ci", "log_likelihood", "aic", "bic", "n"):
        assert key in fitted
    assert fitted["n"] == len(simulated) and fitted["aic"] == pytest.approx(2 * 5 - 2 * fitted["log_likelihood"])
    with open(tmp_path / "comparison.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    assert list(table[0])[:5] == ["model", "log_likelihood", "aic", "bic", "n_parameters"]
    with open(tmp_path / "lrt.csv", newline="") as fh:
        lrt = list(csv.DictReader(fh))
    assert lrt[0]["restricted"] == "mechanistic/no_command_remap" and float(lrt[0]["p_value"]) < 1e-3


@pytest.mark.slow
def test_fit_resumes_from_its_cache_and_log(simulated, tmp_path):
    """The observations are cached (npz, no pickle) and re-used; the same fit again is a no-op; with
    fit.json deleted the logged evaluations are replayed to the same result; a damaged cache is redone."""
    small = type(simulated)(*(getattr(simulated, f)[:48] for f in ("amplitude_deg", "flash_time_ms", "true_deg",
                                                                   "perceived_deg", "condition", "n", "sd_deg")),
                            simulated.source)
    first = fit(small, "mechanistic", tmp_path, max_evals=20, workers=1)
    cache = list((tmp_path / "observations").glob("*.npz"))
    assert cache and (tmp_path / "fit_log.csv").exists() and not list(tmp_path.rglob("*.pkl"))
    n_log = sum(1 for _ in open(tmp_path / "fit_log.csv"))
    stamp = [p.stat().st_mtime_ns for p in cache]
    again = fit(small, "mechanistic", tmp_path, max_evals=20, workers=1)
    assert again["already_done"] and again["parameters"] == first["parameters"]
    (tmp_path / "fit.json").unlink()
    second = fit(small, "mechanistic", tmp_path, max_evals=20, workers=1)
    assert [p.stat().st_mtime_ns for p in cache] == stamp  # observations re-used, not rendered again
    assert sum(1 for _ in open(tmp_path / "fit_log.csv")) == n_log  # every evaluation read back from the log
    assert {k: v for k, v in second.items() if k != "already_done"} == \
        {k: v for k, v in first.items() if k != "already_done"}
    cache[0].write_bytes(b"torn")  # a damaged cache is redone, not trusted
    (tmp_path / "fit.json").unlink()
    third = fit(small, "mechanistic", tmp_path, max_evals=20, workers=1)
    assert third["parameters"] == first["parameters"]


def test_cli_usage_errors(tmp_path, capsys):
    from experiments.__main__ import main

    bad = _write(tmp_path / "bad.csv", GOOD[:3], [[20, 0, 1]])
    with pytest.raises(SystemExit) as e:
        main(["fit", "--data", str(bad), "--model", "mechanistic", "--out", str(tmp_path / "o")])
    assert e.value.code == 2 and "missing column" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main(["fit", "--data", str(bad), "--model", "bayes", "--out", str(tmp_path / "o")])
    assert e.value.code == 2
    with pytest.raises(SystemExit) as e:
        main(["simulate", "--params", "feedback_gain=99", "--out", str(tmp_path / "s.csv")])
    assert e.value.code == 2 and "feedback_gain" in capsys.readouterr().err
