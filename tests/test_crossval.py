"""``python -m experiments crossval``: fit on some conditions, predict held-out ones (issue 34, item 4)."""

from __future__ import annotations

import contextlib
import csv
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from experiments.__main__ import main
from experiments.modelfit.crossval import COLUMNS, HELDOUT, PAIR_COLUMNS, _claim_folder, paired_difference, score, settings
from procs import holding, reap

ROOT = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, PYTHONPATH=str(ROOT))
#: Two theories of different kinds, each generating data and each fitted: 2 data sets x 2 fit sets x 2 fits.
THEORIES = "observer,paper"
QUICK = ["--quick", "--theories", THEORIES, "--data-from", THEORIES, "--no-progress"]


def _rows(out: Path) -> list[dict]:
    return list(csv.DictReader((out / "crossval.csv").open()))


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """An uninterrupted quick cross-validation (and the bytes of its table)."""
    out = tmp_path_factory.mktemp("crossval") / "ref"
    assert main(["crossval", "--out", str(out), *QUICK]) == 0
    return out, (out / "crossval.csv").read_bytes()


# ---------------------------------------------------------------------------------------------- scoring
def test_score_matches_a_direct_sum():
    """Log-likelihood per report and RMSE against a direct sum over the reports (scipy's normal
    log-density); trials whose flash is lost are left out and counted; the CI brackets the value."""
    from scipy.stats import norm

    rng = np.random.default_rng(3)
    pred = rng.normal(0, 5, (6, 2))
    pred[4] = np.nan  # a lost flash
    trial = np.repeat(np.arange(6), 3)
    rows = np.zeros((len(trial), 8))
    rows[:, 6] = trial
    rows[:, 4:6] = np.nan_to_num(pred[trial]) + rng.normal(0, 1.3, (len(trial), 2))
    noise = (1.1, 1.7)
    s = score(rows, pred, noise, (0, 1), np.random.default_rng(0))
    keep = trial != 4
    d = rows[keep, 4:6] - pred[trial[keep]]
    ll = norm.logpdf(d[:, 0], scale=1.1) + norm.logpdf(d[:, 1], scale=1.7)
    assert s["n"] == keep.sum() == 15 and s["lost"] == 1
    assert s["loglik_per_report"][0] == pytest.approx(ll.mean(), rel=1e-12)
    assert s["rmse_deg"][0] == pytest.approx(math.sqrt(np.mean(d**2)), rel=1e-12)
    for m in ("loglik_per_report", "rmse_deg"):
        v, lo, hi = s[m]
        assert lo <= v <= hi and lo < hi
    # one axis: the y axis alone, with the noise given for it
    s1 = score(rows, pred, noise, (1,), np.random.default_rng(0))
    assert s1["loglik_per_report"][0] == pytest.approx(norm.logpdf(d[:, 1], scale=1.7).mean(), rel=1e-12)
    assert s1["rmse_deg"][0] == pytest.approx(math.sqrt(np.mean(d[:, 1] ** 2)), rel=1e-12)


def test_score_of_two_flashes_per_trial_matches_a_direct_sum():
    """Separation: each report row names its flash (column 8) and is scored against that flash's
    prediction; a trial with either flash lost is left out whole."""
    from scipy.stats import norm

    rng = np.random.default_rng(4)
    pred = rng.normal(0, 5, (5, 2, 2))
    pred[3, 1] = np.nan  # the second flash of trial 3 lost
    trial = np.repeat(np.arange(5), 4)
    flash = np.tile([0, 1], 10)
    rows = np.zeros((len(trial), 9))
    rows[:, 6], rows[:, 8] = trial, flash
    rows[:, 4:6] = np.nan_to_num(pred[trial, flash]) + rng.normal(0, 1.2, (len(trial), 2))
    s = score(rows, pred, (1.0, 1.5), (0, 1), np.random.default_rng(0))
    keep = trial != 3
    d = rows[keep, 4:6] - pred[trial[keep], flash[keep]]
    assert s["n"] == 16 and s["lost"] == 1
    ll = norm.logpdf(d[:, 0], scale=1.0) + norm.logpdf(d[:, 1], scale=1.5)
    assert s["loglik_per_report"][0] == pytest.approx(ll.mean(), rel=1e-12)
    assert set(s["per_trial"]) == {0, 1, 2, 4} and all(c == 4 for _, c in s["per_trial"].values())


def test_binary_score_matches_a_direct_sum():
    """Displacement: each forward/backward report's Bernoulli log-likelihood under its cell's predicted
    probability (scipy's normal CDF of perceived step over report s.d.), averaged; the CI brackets it."""
    from scipy.stats import bernoulli, norm

    from experiments.modelfit.crossval import score_binary

    rng = np.random.default_rng(5)
    z = np.array([-2.0, -0.5, 0.0, 0.7, 3.0])
    cell = np.repeat(np.arange(5), 6)
    reported = rng.random(len(cell)) < norm.cdf(z[cell])
    rows = np.zeros((len(cell), 6))
    rows[:, 3], rows[:, 4] = reported, cell
    logp = np.column_stack([norm.logcdf(z), norm.logcdf(-z)])
    s = score_binary(rows, logp, np.random.default_rng(0))
    want = bernoulli.logpmf(reported.astype(int), norm.cdf(z[cell])).mean()
    assert s["loglik_per_report"][0] == pytest.approx(want, rel=1e-12)
    v, lo, hi = s["loglik_per_report"]
    assert lo <= v <= hi and lo < hi and s["n"] == 30 and all(math.isnan(x) for x in s["rmse_deg"])


def test_paired_difference_matches_a_direct_sum():
    """The paired difference per report over the trials both theories predict; its interval
    brackets it; a constant lead has a zero-width interval at that lead."""
    a = {0: (-4.0, 2.0), 1: (-6.0, 2.0), 2: (-3.0, 1.0), 3: (-9.0, 2.0)}
    b = {0: (-5.0, 2.0), 1: (-6.5, 2.0), 2: (-3.5, 1.0)}  # trial 3 lost by b
    d, lo, hi, n = paired_difference(a, b, np.random.default_rng(0))
    assert n == 5 and d == pytest.approx((1.0 + 0.5 + 0.5) / 5)
    assert lo <= d <= hi
    shifted = {t: (v - 0.3 * c, c) for t, (v, c) in a.items()}
    d, lo, hi, _ = paired_difference(a, shifted, np.random.default_rng(0))
    assert d == pytest.approx(0.3) and lo == pytest.approx(0.3) and hi == pytest.approx(0.3)
    assert math.isnan(paired_difference(a, {}, np.random.default_rng(0))[0])


@pytest.mark.adversarial
def test_settings_refuse_bad_values():
    for kw, msg in ((dict(theories=["nope"]), "unknown theory"), (dict(theories=[]), "at least one"),
                    (dict(data_from=["paper", "paper"]), "listed twice"), (dict(noise_deg=float("nan")), "noise_deg"),
                    (dict(noise_deg=0.0), "noise_deg")):
        with pytest.raises(ValueError, match=msg):
            settings(**kw)


# ---------------------------------------------------------------------------------------------- the command
@pytest.mark.slow
def test_table_is_consistent_and_a_rerun_is_a_no_op(reference):
    """One row per data set x theory x fit set x scored condition x metric; CIs bracket the values;
    n = trials x reports; nothing lost at the defaults; the figure and summary exist; the data files
    load through ``fit``'s reader; the same command again changes nothing."""
    from experiments.modelfit import read_data
    from experiments.modelfit.forward import ForwardModelError, forward_model

    out, ref = reference
    rows = _rows(out)
    assert list(rows[0]) == COLUMNS
    theories = THEORIES.split(",")
    scored = sum(1 + len(h) for _, _, h in HELDOUT.values())
    assert len(rows) == len(theories) * len(theories) * scored * 2
    keys = [(r["data"], r["theory"], r["fit_set"], r["condition"], r["metric"]) for r in rows]
    assert len(set(keys)) == len(keys)
    for r in rows:
        if r["condition"] == "displacement":  # 4 steps x 2 blanks x 2 repetitions, one report each; at 64 px
            # the 3 deg step seen at landing (blank 0) is lost by every theory: those 2 reports are counted out
            assert int(r["n"]) == 14 and int(r["lost"]) == 2, r
            if r["metric"] == "rmse_deg":  # a direction report has no position error
                assert r["value"] == r["ci_low"] == r["ci_high"] == "", r
                continue
        else:  # 4 flashes x 4 times x 2 reports (separation: each report gives both flashes)
            assert int(r["n"]) == 4 * 4 * 2 * (2 if r["condition"] == "separation" else 1) and int(r["lost"]) == 0, r
        v, lo, hi = float(r["value"]), float(r["ci_low"]), float(r["ci_high"])
        assert lo <= v <= hi, r
        assert (v > 0) if r["metric"] == "rmse_deg" else math.isfinite(v)
    assert {r["role"] for r in rows if r["condition"] in (
        "dark", "marker", "separation", "displacement", "references (y)")} == {"held-out"}
    # the paired comparison: best minus runner-up, as the table's own values say
    pairs = list(csv.DictReader((out / "crossval_pairs.csv").open()))
    assert list(pairs[0]) == PAIR_COLUMNS and len(pairs) == len(theories) * 5
    ll = {(r["data"], r["condition"], r["theory"]): float(r["value"]) for r in rows
          if r["metric"] == "loglik_per_report" and r["role"] == "held-out"}
    for p in pairs:
        best, second = ll[p["data"], p["condition"], p["best"]], ll[p["data"], p["condition"], p["runner_up"]]
        assert best >= second and best == max(v for (d, c, _), v in ll.items() if (d, c) == (p["data"], p["condition"]))
        d = float(p["delta_loglik_per_report"])
        assert d == pytest.approx(best - second, abs=2e-6)
        assert float(p["ci_low"]) <= d <= float(p["ci_high"])
        assert p["separated"] == str(float(p["ci_low"]) > 0)
    assert (out / "crossval.png").stat().st_size > 5000
    text = (out / "summary.txt").read_text()
    assert "predicted, never fitted: separation" in text and "displacement" in text
    assert "simulated observers" in text
    cfg = json.loads((out / "crossval.json").read_text())
    assert cfg["settings"]["theories"] == theories and cfg["settings"]["quick"] is True
    for gen in theories:
        for cond in ("references", "dark", "marker"):
            assert len(read_data(out / "data" / gen / f"{cond}.csv")) == 32
        sep = read_data(out / "data" / gen / "separation.csv")  # both flashes of each report, fit refuses it
        assert len(sep) == 64
        with pytest.raises(ForwardModelError, match="separation paradigm"):
            forward_model(sep)
        disp = list(csv.DictReader((out / "data" / gen / "displacement.csv").open()))
        assert len(disp) == 16 and {r["reported_forward"] for r in disp} == {"0", "1"}
    assert main(["crossval", "--out", str(out), *QUICK]) == 0
    assert (out / "crossval.csv").read_bytes() == ref
    assert not (out / ".lock").exists()


@pytest.mark.slow
def test_each_theory_predicts_its_own_held_out_conditions_best(reference):
    """Ground truth by construction: data simulated by theory G (motor and report noise; no fitted
    theory reads out the observations the data came from). Fitted on the references condition, G
    predicts the held-out dark, marker and separation conditions with a higher log-likelihood per report
    than the theory of another kind; fitted on x alone, the paper's curve predicts its own y errors best. At
    this quick scale (16 trials x 2 reports, 15 evaluations) the observer fitted on x alone is not
    identified -- its prior and timing s.d. run to their bounds (0.5 deg, 5 ms; the x-likelihood at
    its own defaults is ~10 lower than there) -- so its x -> y case is checked at full scale, in the
    committed table (``test_committed_table_ranks_each_generating_theory_first``)."""
    out, _ = reference
    rows = [r for r in _rows(out) if r["role"] == "held-out" and r["metric"] == "loglik_per_report"]
    by = {(r["data"], r["condition"], r["theory"]): float(r["value"]) for r in rows}
    cases = [
        (g, o, c) for g, o in (("observer", "paper"), ("paper", "observer")) for c in ("dark", "marker", "separation")
    ]
    for gen, other, cond in cases + [("paper", "observer", "references (y)")]:
        mine, theirs = by[f"simulated:{gen}", cond, gen], by[f"simulated:{gen}", cond, other]
        assert mine > theirs, (gen, cond, mine, theirs)


def test_committed_table_ranks_each_generating_theory_first():
    """The committed full-scale run (``experiments/data/crossval.csv``: 128 px, 8 x 8 trials x 2
    reports, 120 evaluations per fit): in 18 of its 20 held-out cases the theory that generated the
    data predicts them best (ground truth by construction); the two others are displacement cases whose
    leader's lead is not separated from 0 (another theory's direction reports, as the docs say)."""
    root = Path(__file__).resolve().parents[1]
    rows = [r for r in csv.DictReader(open(root / "experiments/data/crossval.csv"))
            if r["role"] == "held-out" and r["metric"] == "loglik_per_report"]
    cases: dict = {}
    for r in rows:
        cases.setdefault((r["data"], r["condition"]), {})[r["theory"]] = float(r["value"])
    assert len(cases) == 20
    pairs = {(p["data"], p["condition"]): p for p in csv.DictReader(open(root / "experiments/data/crossval_pairs.csv"))}
    for (data, cond), scores in cases.items():
        if max(scores, key=scores.get) != data.split(":", 1)[1]:
            # the docs' exceptions: displacement reports another theory predicts as well, its lead not separated
            assert cond == "displacement" and pairs[data, cond]["separated"] == "False", (data, cond, scores)
    assert sum(max(s, key=s.get) == d.split(":", 1)[1] for (d, _), s in cases.items()) == 18


@pytest.mark.slow
def test_kill_9_then_resume_gives_the_uninterrupted_table(reference, tmp_path):
    """kill -9 in the middle of the fits; the same command continues to the same table, byte for byte
    (resumed with its progress bars on stderr: every stage says where it is, the results unchanged)."""
    _, ref = reference
    out = tmp_path / "k9"
    cmd = [sys.executable, "-m", "experiments", "crossval", "--out", str(out), *QUICK]
    proc = subprocess.Popen(cmd, env=ENV, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        logs = out / "fits" / "observer" / "references"
        deadline = time.monotonic() + 300
        while proc.poll() is None and time.monotonic() < deadline:
            done = [p for p in logs.glob("*/fit_log.csv") if p.read_bytes().count(b"\n") > 5]
            if done:
                break
            time.sleep(0.02)
        with contextlib.suppress(ProcessLookupError):
            os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        assert not (out / "crossval.csv").exists()  # killed before it finished
        r = subprocess.run([c for c in cmd if c != "--no-progress"], env=ENV, cwd=ROOT, capture_output=True,
                           text=True)
        assert r.returncode == 0, r.stderr
        for stage in ("warm-up", "crossval: displacement reports", "crossval: fits"):
            assert stage in r.stderr, (stage, r.stderr[-2000:])
        assert (out / "crossval.csv").read_bytes() == ref
        assert not (out / ".lock").exists()
    finally:
        reap(proc, [])


@pytest.mark.slow
def test_sigterm_says_how_to_resume(tmp_path):
    """SIGTERM during the work: exit 143, one line saying how to resume, no traceback, no lock left."""
    out = tmp_path / "term"
    cmd = [sys.executable, "-m", "experiments", "crossval", "--out", str(out), *QUICK]
    proc = subprocess.Popen(cmd, env=ENV, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 300
        while proc.poll() is None and time.monotonic() < deadline and not (out / "crossval.json").exists():
            time.sleep(0.02)
        time.sleep(1.0)  # into the warm-up or the observing
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
        assert proc.returncode == 143, err
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert len(lines) == 1 and "Traceback" not in err, err
        assert "interrupted (SIGTERM)" in lines[0] and "run the same command again" in lines[0]
        assert not (out / ".lock").exists()
    finally:
        reap(proc, [])


# ---------------------------------------------------------------------------------------------- hostile options
def _usage(argv: list[str], capsys, *words: str) -> None:
    with pytest.raises(SystemExit) as e:
        main(argv)
    err = capsys.readouterr().err
    assert e.value.code == 2, err
    assert "Traceback" not in err and "usage:" in err
    for w in words:
        assert w in err, err


@pytest.mark.adversarial
@pytest.mark.parametrize("extra, word", [
    (["--reports", "0"], "--reports"), (["--noise-deg", "nan"], "--noise-deg"), (["--noise-deg", "-1"], "--noise-deg"),
    (["--theories", "nope"], "--theories"), (["--theories", "paper,paper"], "listed twice"),
    (["--data-from", ""], "--data-from"), (["--image-size", "8"], "--image-size"), (["--max-evals", "5"], "--max-evals"),
    (["--seed", "-1"], "--seed"), (["--seed", "1.5"], "--seed"), (["--workers", "0"], "--workers"),
    (["--backend", "slurm"], "--backend"), (["--ray-address", "auto"], "--ray-address"), (["--quik"], "--quick"),
])
def test_bad_options_are_usage_errors(extra, word, capsys, tmp_path):
    _usage(["crossval", "--out", str(tmp_path / "o"), *extra], capsys, word)


@pytest.mark.adversarial
def test_folders_it_cannot_use(capsys, tmp_path):
    """A file as --out, a folder of another configuration, a damaged crossval.json: usage errors
    before any work; a folder in use by another process: exit 1, one line."""
    f = tmp_path / "file"
    f.write_text("x")
    _usage(["crossval", "--out", str(f), "--quick"], capsys, "--out", "not a folder")
    _usage(["crossval"], capsys, "--out")
    other = tmp_path / "other"
    other.mkdir()
    _claim_folder(other, settings(quick=True, seed=1))
    _usage(["crossval", "--out", str(other), "--quick", "--seed", "0"], capsys, "another configuration", "seed")
    (other / "crossval.json").write_text('{"key": "0", "settings": {}}')
    _usage(["crossval", "--out", str(other), "--quick"], capsys, "damaged")
    busy = tmp_path / "busy"
    busy.mkdir()
    with holding("experiments.psychophysics.runner.folder_lock", busy, ENV):
        assert main(["crossval", "--out", str(busy), "--quick", "--no-progress"]) == 1
    err = capsys.readouterr().err
    assert "in use by another run" in err and "Traceback" not in err


def test_docs_table_is_rendered_from_the_committed_csv():
    """The docs' held-out table is ``markdown_table`` of ``experiments/data/crossval.csv`` (one source
    for each number), and that run's summary claims hold in the CSVs: the generating theory best in
    every held-out case, and ``crossval_pairs.csv`` agreeing with the table on who is best."""
    import csv

    from experiments.modelfit.crossval import markdown_table, winners

    root = Path(__file__).resolve().parents[1]
    rows = list(csv.DictReader(open(root / "experiments/data/crossval.csv")))
    pairs = list(csv.DictReader(open(root / "experiments/data/crossval_pairs.csv")))
    assert markdown_table(rows) in (root / "docs/psychophysics/crossval.md").read_text()
    wins = winners(rows)
    assert len(wins) == 20 and sum(w["best"] == w["data"].split(":", 1)[1] for w in wins) == 18
    assert {(p["data"], p["condition"], p["best"]) for p in pairs} == {
        (w["data"], w["condition"], w["best"]) for w in wins}
