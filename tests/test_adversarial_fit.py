"""``fit``, ``compare``, ``simulate`` and ``phenomena`` keep ``run``'s promises (issue 21).

No code runs from a results folder (a planted pickle, a tampered cache), one writer per folder
(a second process gets one line), no ``.lock`` left behind, workers die with a killed parent, a fit
is a function of its data and options (re-run, deleted output, torn log, ``kill -9`` and resume:
the same ``fit.json``), a fit that cannot fit says so naming the rows, strict JSON, and every bad
command line is a usage error before any work. Each case is marked ``adversarial``; the ones that
start processes or fit are also ``slow``.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from experiments.__main__ import main
from experiments.modelfit import read_data, simulate_data
from experiments.modelfit.fitting import FitError, FitFolderError, compare, fit
from experiments.psychophysics import Design, TrialConfig
from procs import children as _children  # tests/procs.py
from procs import cmdline as _cmdline
from procs import gone as _gone
from procs import holding, reap

pytestmark = pytest.mark.adversarial

ROOT = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, PYTHONPATH=str(ROOT))
MODEL = "mechanistic/no_command_remap"  # two free parameters: the cheapest real fit
TRUTH = {"eps_sigma_ms": 40.0, "eps_delay_ms": 60.0, "noise_x_deg": 0.7, "noise_y_deg": 0.6}
TINY = Design(amplitudes_deg=(20.0,), flash_offsets_deg=((-8.0, 3.0), (4.0, -3.0)), flash_times_ms=(-100, 0, 50),
              seed=3)
FAST = dict(max_evals=10, workers=1)


def _strict(text: str):
    """JSON that refuses NaN and infinities (what other JSON readers do)."""
    def bad(token):
        raise ValueError(f"non-standard JSON constant {token}")
    return json.loads(text, parse_constant=bad)


@pytest.fixture(scope="module")
def data_file(tmp_path_factory) -> Path:
    """A 12-row data set simulated at 64 px, with its sidecar (the fit's forward model)."""
    path = tmp_path_factory.mktemp("data") / "tiny.csv"
    simulate_data(MODEL, TRUTH, TINY, conditions=("references",), reports=2, seed=1, out_csv=path,
                  config=TrialConfig(image_size=64))
    return path


@pytest.fixture(scope="module")
def reference_fit(data_file, tmp_path_factory) -> tuple[Path, bytes]:
    """One uninterrupted fit: its folder and the bytes of its fit.json."""
    out = tmp_path_factory.mktemp("ref")
    fit(read_data(data_file), MODEL, out, **FAST)
    return out, (out / "fit.json").read_bytes()


# ---------------------------------------------------------------------------------------------- 1. no code
class _Boom:
    """Unpickling this writes a marker file: proof that code ran."""

    def __init__(self, marker: str) -> None:
        self.marker = marker

    def __reduce__(self):
        return (Path.write_text, (Path(self.marker), "pwned"))


@pytest.mark.slow
def test_a_planted_pickle_never_runs_and_the_cache_is_rebuilt(data_file, reference_fit, tmp_path, capsys):
    """A pickle under OUT/observations (as .pkl, and inside an .npz named like the real cache) is
    never executed; the cache is rebuilt with a message and the fit equals the clean one."""
    import pickle

    ref_dir, ref = reference_fit
    out = tmp_path / "planted"
    (out / "observations").mkdir(parents=True)
    marker = tmp_path / "marker.txt"
    for npz in (ref_dir / "observations").glob("*.npz"):
        (out / "observations" / npz.name.replace(".npz", ".pkl")).write_bytes(pickle.dumps(_Boom(str(marker))))
        np.savez(out / "observations" / npz.name, meta=np.array([_Boom(str(marker))], dtype=object))
    fit(read_data(data_file), MODEL, out, **FAST)
    assert not marker.exists()
    assert "observing its" in capsys.readouterr().err  # said why it observed again
    assert (out / "fit.json").read_bytes() == ref


@pytest.mark.slow
@pytest.mark.parametrize("damage", ["truncate", "flip", "foreign-array"])
def test_a_damaged_cache_is_rebuilt_not_trusted(data_file, reference_fit, tmp_path, capsys, damage):
    ref_dir, ref = reference_fit
    out = tmp_path / damage
    (out / "observations").mkdir(parents=True)
    for npz in (ref_dir / "observations").glob("*.npz"):
        raw = npz.read_bytes()
        target = out / "observations" / npz.name
        if damage == "truncate":
            target.write_bytes(raw[: len(raw) // 2])
        elif damage == "flip":
            b = bytearray(raw)
            b[len(b) // 2] ^= 0xFF
            target.write_bytes(bytes(b))
        else:  # a well-formed npz whose numbers were changed: the checksum no longer matches
            with np.load(npz, allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files}
            arrays["target_deg"] = arrays["target_deg"] + 1.0
            np.savez(target, **arrays)
    fit(read_data(data_file), MODEL, out, **FAST)
    assert "observing its" in capsys.readouterr().err
    assert (out / "fit.json").read_bytes() == ref


# ---------------------------------------------------------------------------------------------- 3. a function
@pytest.mark.slow
def test_a_fit_is_a_function_of_its_data_and_options(data_file, reference_fit, tmp_path, capsys):
    """Re-run: a no-op that says so. Deleted fit.json, torn log line: the same bytes again. Strict JSON."""
    ref_dir, ref = reference_fit
    _strict(ref.decode())
    r = fit(read_data(data_file), MODEL, ref_dir, **FAST)
    assert r["already_done"] and "nothing to do" in capsys.readouterr().err
    assert (ref_dir / "fit.json").read_bytes() == ref
    out = tmp_path / "again"
    out.mkdir()
    for name in ("fit_log.csv",):
        (out / name).write_bytes((ref_dir / name).read_bytes() + b"2f3a,torn-li")  # a torn last line
    fit(read_data(data_file), MODEL, out, **FAST)
    assert "dropped 1 torn" in capsys.readouterr().err
    assert (out / "fit.json").read_bytes() == ref
    assert not (out / ".lock").exists() and not list(out.glob("*.tmp")) and not list(out.glob(".*.tmp"))


@pytest.mark.slow
def test_a_folder_holding_another_fit_is_refused(data_file, reference_fit, tmp_path, capsys):
    ref_dir, _ = reference_fit
    out = tmp_path / "other"
    out.mkdir()
    for name in ("fit.json", "fit.png", "fitted_trials.csv"):
        (out / name).write_bytes((ref_dir / name).read_bytes())
    with pytest.raises(FitFolderError, match="holds a fit of another model"):
        fit(read_data(data_file), MODEL, out, max_evals=11, workers=1)  # other options: another fit
    _usage(["fit", "--data", str(data_file), "--model", MODEL, "--out", str(out), "--max-evals", "11",
            "--no-progress"], capsys, "--out", "holds a fit of another model")


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_kill_9_then_resume_gives_the_uninterrupted_fit(data_file, reference_fit, tmp_path):
    """kill -9 of a 2-worker fit: its workers exit with it; the same command resumes to the same
    fit.json as an uninterrupted run (and leaves no lock)."""
    _, ref = reference_fit
    out = tmp_path / "k9"
    cmd = [sys.executable, "-m", "experiments", "fit", "--data", str(data_file), "--model", MODEL, "--out", str(out),
           "--max-evals", "10", "--workers", "2", "--no-progress"]
    proc = subprocess.Popen(cmd, env=ENV, cwd=ROOT, start_new_session=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    kids: list[int] = []
    try:
        while proc.poll() is None and len(kids) < 2:  # until the observing workers run
            kids = [k for k in _children(proc.pid) if "spawn_main" in _cmdline(k)]
            time.sleep(0.05)
        assert proc.poll() is None and len(kids) >= 2
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        assert _gone(kids) == []
        r = subprocess.run(cmd, env=ENV, cwd=ROOT, capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        assert (out / "fit.json").read_bytes() == ref
        # killed again in the middle of its evaluations, resumed again: still the same bytes
        (out / "fit.json").unlink()
        log = out / "fit_log.csv"
        lines = log.read_bytes().splitlines(keepends=True)
        half = len(lines) // 2
        log.write_bytes(b"".join(lines[:half]))  # half of the evaluations to compute again
        proc = subprocess.Popen(cmd, env=ENV, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        while proc.poll() is None and log.read_bytes().count(b"\n") < half + 3:
            time.sleep(0.01)
        with contextlib.suppress(ProcessLookupError):
            os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        assert not (out / "fit.json").exists()  # killed before it finished
        r = subprocess.run(cmd, env=ENV, cwd=ROOT, capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        assert (out / "fit.json").read_bytes() == ref
        assert not (out / ".lock").exists()
    finally:
        reap(proc, kids)


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["sigterm", "ctrl-c"])
def test_an_interrupted_fit_says_how_to_resume(data_file, tmp_path, sig):
    """SIGTERM or Ctrl-C (to the process group) during the evaluations: exit 128 + signal, one line, no traceback."""
    out = tmp_path / "int"
    cmd = [sys.executable, "-m", "experiments", "fit", "--data", str(data_file), "--model", MODEL, "--out", str(out),
           "--max-evals", "10", "--workers", "1", "--no-progress"]
    proc = subprocess.Popen(cmd, env=ENV, cwd=ROOT, start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    log = out / "fit_log.csv"
    while proc.poll() is None and not (log.exists() and log.read_bytes().count(b"\n") >= 3):
        time.sleep(0.01)
    os.killpg(proc.pid, sig) if sig == signal.SIGINT else os.kill(proc.pid, sig)
    _, err = proc.communicate()
    assert proc.returncode == 128 + sig, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert f"interrupted ({sig.name})" in lines[0] and "run the same command again" in lines[0]
    assert not (out / ".lock").exists()


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_kill_9_of_a_ray_fit_leaves_no_observers(data_file, tmp_path):
    """The Ray backend's observing actors (each holding MuJoCo and a renderer) exit with a killed driver."""
    pytest.importorskip("ray")
    cmd = [sys.executable, "-m", "experiments", "fit", "--data", str(data_file), "--model", MODEL, "--out",
           str(tmp_path / "ray"), "--backend", "ray", "--workers", "2", "--no-progress"]
    proc = subprocess.Popen(cmd, env=ENV, cwd=ROOT, start_new_session=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    observers: list[int] = []
    try:
        while proc.poll() is None and len(observers) < 2:
            observers = [int(d.name) for d in Path("/proc").iterdir()
                         if d.name.isdigit() and _cmdline(int(d.name)).startswith("ray::ExperimentWorker")]
            time.sleep(0.05)
        assert proc.poll() is None and len(observers) >= 2
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        assert _gone(observers) == []
    finally:
        reap(proc, observers)


# ---------------------------------------------------------------------------------------------- 4. cannot fit
@pytest.mark.slow
@pytest.mark.parametrize("rows", ["all", "some"])
def test_a_model_that_loses_the_flashes_fails_naming_the_rows(data_file, tmp_path, capsys, rows):
    """Flashes at 55 deg (outside the eyes' view at the fixed gaze): exit 1 naming the rows, no
    fit.json, never a log-likelihood of -1e12 or NaN predictions."""
    lines = data_file.read_text().splitlines()
    head, body = lines[0], lines[1:]
    cols = head.split(",")
    i_x, i_dx = cols.index("true_x_deg"), cols.index("flash_dx_deg")
    moved = range(len(body)) if rows == "all" else (2, 5)
    for k in moved:
        f = body[k].split(",")
        f[i_x], f[i_dx] = "55", str(55 - 10)
        body[k] = ",".join(f)
    bad = tmp_path / "far.csv"
    bad.write_text("\n".join([head, *body]) + "\n")
    (tmp_path / "far.json").write_bytes(data_file.with_suffix(".json").read_bytes())
    out = tmp_path / "out"
    with pytest.raises(FitError) as e:
        fit(read_data(bad), MODEL, out, **FAST)
    named = [k + 2 for k in moved][:10]
    assert all(str(r) in str(e.value) for r in named), e.value
    assert not (out / "fit.json").exists()
    code = main(["fit", "--data", str(bad), "--model", MODEL, "--out", str(out), "--max-evals", "10", "--workers",
                 "1", "--no-progress"])
    err = capsys.readouterr().err
    assert code == 1 and "cannot be fitted" in err and "Traceback" not in err
    assert f"rows ({named[0]}, {named[1]}" in err


# ---------------------------------------------------------------------------------------------- 2. one writer
@pytest.mark.slow
@pytest.mark.parametrize("command", ["fit", "compare", "simulate", "phenomena"])
def test_a_second_process_gets_one_line(data_file, tmp_path, capsys, command):
    from experiments.folders import path_lock

    out = tmp_path / ("s.csv" if command == "simulate" else "busy")
    lock = (out.parent / f".{out.name}.lock") if command == "simulate" else out / ".lock"
    out.parent.mkdir(parents=True, exist_ok=True)
    if command != "simulate":
        out.mkdir()
    with holding("experiments.folders.path_lock", lock, ENV) as holder:
        argv = {"fit": ["fit", "--data", str(data_file), "--model", MODEL, "--out", str(out)],
                "compare": ["compare", "--data", str(data_file), "--models", MODEL, "--out", str(out)],
                "simulate": ["simulate", "--amplitudes", "20", "--image-size", "32", "--out", str(out)],
                "phenomena": ["phenomena", "--out", str(out)]}[command]
        code = main([*argv, "--no-progress"])
        err = capsys.readouterr().err
        assert code == 1, err
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert len(lines) == 1 and "is in use by another run" in lines[0] and f"pid {holder.pid}" in lines[0], err
    with path_lock(lock):  # released with its holder, and removed
        pass
    assert not lock.exists()


# ---------------------------------------------------------------------------------------------- 6. usage errors
LONG = "x" * 300


def _usage(argv: list[str], capsys, *words: str) -> None:
    with pytest.raises(SystemExit) as e:
        main(argv)
    err = capsys.readouterr().err
    assert e.value.code == 2, err
    assert "Traceback" not in err and "usage:" in err
    for w in words:
        assert w in err, err


@pytest.mark.parametrize("case", ["fit-long", "compare-long", "phenomena-long", "run-long", "simulate-long",
                                  "fit-file", "compare-file", "phenomena-file", "simulate-dir", "simulate-json",
                                  "simulate-nan", "simulate-negative", "simulate-huge", "simulate-duplicate",
                                  "run-duplicate", "run-duplicate-times", "ray-address-local", "compare-twice",
                                  "params-nan", "params-twice"])
def test_cli_paths_are_usage_errors(data_file, tmp_path, capsys, case):
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    d = str(data_file)
    fit_ = ["fit", "--data", d, "--model", MODEL, "--out"]
    cmp_ = ["compare", "--data", d, "--models", MODEL, "--out"]
    sim = ["simulate", "--out"]
    argv, words = {
        "fit-long": ([*fit_, str(tmp_path / LONG)], ["--out", "bytes long"]),
        "compare-long": ([*cmp_, str(tmp_path / LONG)], ["--out", "bytes long"]),
        "phenomena-long": (["phenomena", "--out", str(tmp_path / LONG)], ["--out", "bytes long"]),
        "run-long": (["run", "--quick", "--out", str(tmp_path / LONG)], ["--out"]),
        "simulate-long": ([*sim, str(tmp_path / (LONG + ".csv"))], ["--out", "bytes long"]),
        "fit-file": ([*fit_, str(a_file)], ["--out", "not a folder"]),
        "compare-file": ([*cmp_, str(a_file)], ["--out", "not a folder"]),
        "phenomena-file": (["phenomena", "--out", str(a_file)], ["--out", "not a folder"]),
        "simulate-dir": ([*sim, str(tmp_path)], ["--out", ".csv"]),
        "simulate-json": ([*sim, str(tmp_path / "x.json")], ["--out", ".csv"]),
        "simulate-nan": ([*sim, str(tmp_path / "s.csv"), "--amplitudes", "nan"], ["--amplitudes"]),
        "simulate-negative": ([*sim, str(tmp_path / "s.csv"), "--amplitudes", "-5"], ["--amplitudes"]),
        "simulate-huge": ([*sim, str(tmp_path / "s.csv"), "--amplitudes", "1000"], ["--amplitudes"]),
        "simulate-duplicate": ([*sim, str(tmp_path / "s.csv"), "--amplitudes", "20,20"], ["--amplitudes", "twice"]),
        "run-duplicate": (["run", "--amplitudes", "20,20", "--out", str(tmp_path / "r")], ["--amplitudes", "twice"]),
        "run-duplicate-times": (["run", "--flash-times", "0,0", "--out", str(tmp_path / "r")], ["twice"]),
        "ray-address-local": ([*fit_, str(tmp_path / "o"), "--ray-address", "auto"], ["--ray-address", "--backend ray"]),
        "compare-twice": (["compare", "--data", d, "--models", "paper,paper", "--out", str(tmp_path / "o")],
                          ["--models", "twice"]),
        "params-nan": ([*sim, str(tmp_path / "s.csv"), "--params", "feedback_gain=nan"], ["--params", "finite"]),
        "params-twice": ([*sim, str(tmp_path / "s.csv"), "--params", "feedback_gain=1,feedback_gain=2"],
                         ["--params", "twice"]),
    }[case]
    t0 = time.process_time()
    _usage(argv, capsys, *words)
    assert time.process_time() - t0 < 20  # refused before any rendering (CPU time, not wall-clock)
    assert not (tmp_path / "s.csv").exists() and not (tmp_path / "s.json").exists()


def test_simulate_out_json_never_overwrites_data(tmp_path, capsys):
    """`--out X.json` used to overwrite the data with its metadata: now refused before any work."""
    target = tmp_path / "keep.json"
    target.write_text("{}")
    _usage(["simulate", "--out", str(target)], capsys, ".csv")
    assert target.read_text() == "{}"


def test_bundled_data_resolves_by_name(tmp_path, monkeypatch):
    """`--data example_localization.csv` (as --help says) resolves to the bundled file from any
    folder, and so from an installed wheel."""
    from experiments.cli.options import bundled_data

    monkeypatch.chdir(tmp_path)
    p = bundled_data("example_localization.csv")
    assert p.is_file() and p.parent.name == "data" and len(read_data(p)) == 576
    (tmp_path / "example_localization.csv").write_text("mine")
    assert bundled_data("example_localization.csv") == Path("example_localization.csv")  # a local file wins


# ---------------------------------------------------------------------------------------------- 7. fit = run
def _round_trip(tmp_path: Path, model: str, run_args: list[str], truth: dict, tol: dict, max_evals: int = 150) -> dict:
    """``run`` writes noise-free data; the fit's forward model at the generating parameters predicts
    them exactly (it is the run's: image size, field of view, design, eye-position settings from
    run.json), and ``fit`` with the generating model brings back its identifiable parameters with
    residuals at the read-out's noise floor (the report-noise bound)."""
    from experiments.modelfit.fitting import prepare
    from experiments.modelfit.likelihood import FIT_MODELS, Evaluator

    out = tmp_path / "run"
    code = main(["run", "--quick", "--image-size", "64", "--model", model.split("/")[0], "--no-recording",
                 "--no-progress", "--workers", "1", "--positions", "morrone", "--flash-times=-100,-50,-25,0,50",
                 *run_args, "--out", str(out)])
    assert code == 0 and not (out / ".lock").exists()  # a finished run leaves no lock file
    data = read_data(out / "trials.csv")
    r = fit(data, model, tmp_path / "fit", max_evals=max_evals, workers=1)
    assert r["forward_model"]["source"].endswith("run.json") and r["forward_model"]["config"]["image_size"] == 64
    m = FIT_MODELS[model]
    at_truth = {p.name: truth.get(p.name, p.default) for p in m.parameters}
    ev = Evaluator(m, data, *prepare(data, tmp_path / "fit"))  # the cached observations
    assert np.abs(ev.predict(at_truth) - data.perceived_deg).max() < 1e-9  # the run's own numbers
    for k, v in tol.items():
        assert abs(r["parameters"][k] - at_truth[k]) <= v, (k, r["parameters"][k], at_truth[k])
    assert max(r["residual_rms_deg"]) < 0.02, r["residual_rms_deg"]
    assert r["parameters"]["noise_x_deg"] == pytest.approx(0.02) and "noise_x_deg" in r["at_bounds"]
    return r


@pytest.mark.slow
def test_fit_reproduces_run_paper(tmp_path):
    _round_trip(tmp_path, "paper", ["--peak-gain", "0.37"], {"peak_gain": 0.37},
                {"peak_gain": 0.01, "peak_time_ms": 2.0, "rise_ms": 2.0, "decay_ms": 2.0})


@pytest.mark.slow
def test_fit_reproduces_run_mechanistic(tmp_path):
    """feedback_gain 3: the prediction at the truth is exact; this design (64 px, five flash times)
    reads the same centroids for feedback_gain 3 to 4.5, so only the signal's timing is checked."""
    _round_trip(tmp_path, "mechanistic", ["--feedback-gain", "3.0"], {"feedback_gain": 3.0},
                {"eps_sigma_ms": 5.0, "eps_delay_ms": 5.0}, max_evals=60)


@pytest.mark.slow
def test_fit_reproduces_run_mechanistic_without_remap(tmp_path):
    _round_trip(tmp_path, "mechanistic/no_command_remap", ["--disable", "command_remap"], {},
                {"eps_sigma_ms": 5.0, "eps_delay_ms": 5.0})


def test_fit_refuses_a_design_it_cannot_reproduce(tmp_path, capsys):
    """Rows of the separation paradigm, or a sidecar that is another table's, are usage errors."""
    from experiments.modelfit.forward import ForwardModelError, forward_model

    head = ("saccade_amplitude_deg,flash_time_ms,true_x_deg,true_y_deg,perceived_x_deg,perceived_y_deg,paradigm,"
            "config_hash")
    p = tmp_path / "trials.csv"
    p.write_text(f"{head}\n20,0,2,3,2,3,separation,abc\n20,50,2,3,2,3,localization,abc\n")
    with pytest.raises(ForwardModelError, match="rows 2 are from the separation paradigm"):
        forward_model(read_data(p))
    p.write_text(f"{head}\n20,50,2,3,2,3,localization,abc\n")
    (tmp_path / "run.json").write_text(json.dumps({"config": {"image_size": 64}, "config_hash": "def"}))
    with pytest.raises(ForwardModelError, match="does not describe"):
        forward_model(read_data(p))
    _usage(["fit", "--data", str(p), "--out", str(tmp_path / "o")], capsys, "--data", "does not describe")


# ---------------------------------------------------------------------------------------------- 8. progress
@pytest.mark.slow
def test_fit_shows_progress(data_file, reference_fit, tmp_path, capsys):
    ref_dir, _ = reference_fit
    out = tmp_path / "p"
    out.mkdir()
    (out / "fit_log.csv").write_bytes((ref_dir / "fit_log.csv").read_bytes())
    fit(read_data(data_file), MODEL, out, progress=True, **FAST)
    err = capsys.readouterr().err
    assert "observing (references)" in err and f"fitting {MODEL}" in err and "eval" in err


@pytest.mark.slow
def test_compare_reuses_finished_fits(data_file, reference_fit, tmp_path, capsys):
    """A comparison whose fits are finished re-fits nothing; its comparison.csv is strict and ranked."""
    out = tmp_path / "cmp"
    rows = compare(read_data(data_file), [MODEL], out, **FAST)
    assert (out / MODEL.replace("/", "_") / "fit.json").read_bytes() == reference_fit[1]
    again = compare(read_data(data_file), [MODEL], out, **FAST)
    assert again == rows and "nothing to do" in capsys.readouterr().err
    assert "nan" not in (out / "comparison.csv").read_text().lower()
