"""Results are never silently wrong (issue 11, item 4): row checksums, configuration hashes, the
folder lock, NaN results, and interrupted or killed runs (workers die with their parent, a resume
hint instead of a traceback), for ``experiments.psychophysics.run_trials`` and ``python -m experiments run``."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
import zlib
from pathlib import Path

import numpy as np
import pytest

from experiments.psychophysics import (
    ROW_COLUMNS, TABLE_COLUMNS, Design, FolderBusyError, RemapTimeCourse, TrialConfig, config_hash, read_table,
    run_trials,
)
from experiments.psychophysics.runner import _make_pool, _scan, _worker_status, folder_lock

ROOT = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, PYTHONPATH=str(ROOT))
TINY = Design(amplitudes_deg=(16.0,), flash_offsets_deg=((-8.0, 3.0), (8.0, -3.0)), flash_times_ms=(0, 150), seed=5)
CFG = TrialConfig(image_size=64)


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    """A finished 4-trial table (in-process), and the BLAS/OpenMP thread counts seen during its trials."""
    from threadpoolctl import threadpool_info

    out = tmp_path_factory.mktemp("finished")
    seen = []
    run_trials(TINY, CFG, out, workers=1, progress=False,
               on_row=lambda r: seen.append({i["internal_api"]: i["num_threads"] for i in threadpool_info()}))
    (out / "threads.txt").write_text(repr(seen))
    return out


def _copy(src: Path, dst: Path) -> Path:
    dst.mkdir(parents=True, exist_ok=True)
    for name in ("trials.csv", "run.json"):
        (dst / name).write_bytes((src / name).read_bytes())
    return dst


def test_every_row_carries_its_configuration_and_a_checksum(finished):
    lines = (finished / "trials.csv").read_bytes().split(b"\r\n")
    assert lines[0].decode() == ",".join(TABLE_COLUMNS) and lines[-1] == b""
    h = config_hash(TINY, CFG)
    assert len(h) == 12
    for line in lines[1:-1]:
        body, _, crc = line.rpartition(b",")
        assert int(crc, 16) == zlib.crc32(body) and len(crc) == 8
        assert body.split(b",")[-1].decode() == h
    t = read_table(finished / "trials.csv")
    assert list(t["config_hash"]) == [h] * TINY.n_trials
    import pyarrow.parquet as pq

    pt = pq.read_table(finished / "trials.parquet")
    assert pt.column("config_hash").to_pylist() == [h] * TINY.n_trials
    assert pt.column("flash_sim_ms").to_pylist() == [int(v) for v in t["flash_sim_ms"]]
    # the hash follows every part of the design and configuration
    assert config_hash(TINY, TrialConfig(image_size=64, timecourse=RemapTimeCourse(peak_gain=0.0))) != h
    assert config_hash(Design(amplitudes_deg=(16.0,), flash_offsets_deg=TINY.flash_offsets_deg,
                              flash_times_ms=(0, 150), seed=6), CFG) != h
    assert config_hash(TINY, TrialConfig(image_size=64)) == h


def test_in_process_trials_use_one_blas_thread(finished):
    seen = eval((finished / "threads.txt").read_text())  # noqa: S307 - our own repr of dicts of ints
    assert seen and all(n == 1 for s in seen for n in s.values()), seen


def test_every_cut_of_the_last_row_is_detected(finished):
    """Whatever byte the interruption stops at, the torn row fails its check (the issue's case: a cut
    inside the last integer column that used to read 36 instead of 360)."""
    data = (finished / "trials.csv").read_bytes()
    start = data.rstrip(b"\r\n").rfind(b"\r\n") + 2
    last = data[start:].rstrip(b"\r\n")
    path = finished.parent / "cut.csv"
    cuts = 0
    for k in range(1, len(last)):
        path.write_bytes(data[:start] + last[:k])
        scan = _scan(path)
        assert len(scan.rows) == TINY.n_trials - 1 and [n for n, _ in scan.bad] == [TINY.n_trials + 1], k
        cuts += 1
    assert cuts > 200
    # a complete row whose newline did not make it is a complete row
    path.write_bytes(data[:start] + last)
    assert len(_scan(path).rows) == TINY.n_trials and not _scan(path).bad


def test_torn_row_inside_the_integer_column_is_redone_on_resume(finished, tmp_path):
    ref = (finished / "trials.csv").read_bytes()
    out = _copy(finished, tmp_path / "torn")
    text = ref.decode()
    cut = text.rstrip("\r\n").rfind(",360,") + len(",36")  # flash_sim_ms 360 cut to 36
    assert cut > 100
    (out / "trials.csv").write_text(text[:cut], newline="")
    with pytest.raises(ValueError, match=r"trials.csv: 1 torn or damaged row\(s\) \(line 5"):
        read_table(out / "trials.csv")
    with pytest.warns(RuntimeWarning, match="line 5"):
        assert len(read_table(out / "trials.csv", partial=True)["trial_id"]) == 3
    redone = []
    run_trials(TINY, CFG, out, workers=1, progress=False, on_row=lambda r: redone.append(int(r["trial_id"])))
    assert redone == [3]
    assert (out / "trials.csv").read_bytes() == ref
    import pyarrow.parquet as pq

    assert pq.read_table(out / "trials.parquet").column("flash_sim_ms").to_pylist()[-1] == 360


def test_damaged_middle_row_is_reported_and_redone(finished, tmp_path, capfd):
    ref = (finished / "trials.csv").read_bytes()
    out = _copy(finished, tmp_path / "damaged")
    lines = ref.split(b"\r\n")
    fields = lines[2].split(b",")
    i = ROW_COLUMNS.index("perceived_x_deg")
    fields[i] = fields[i][:-1] + (b"0" if fields[i][-1:] != b"0" else b"1")  # one digit changed
    lines[2] = b",".join(fields)
    (out / "trials.csv").write_bytes(b"\r\n".join(lines))
    with pytest.raises(ValueError, match="line 3: checksum mismatch"):
        read_table(out / "trials.csv")
    redone = []
    run_trials(TINY, CFG, out, workers=1, progress=False, on_row=lambda r: redone.append(int(r["trial_id"])))
    assert redone == [1]
    assert "dropped 1 torn or damaged row(s) (line 3: checksum mismatch" in capfd.readouterr().err
    assert (out / "trials.csv").read_bytes() == ref


def test_read_table_refuses_rows_of_two_configurations_and_repeated_ids(finished, tmp_path):
    lines = (finished / "trials.csv").read_bytes().decode().split("\r\n")
    body = lines[2].rpartition(",")[0].rpartition(",")[0] + ",0123456789ab"
    mixed = tmp_path / "mixed.csv"
    mixed.write_text("\r\n".join([lines[0], lines[1], f"{body},{zlib.crc32(body.encode()):08x}", ""]), newline="")
    with pytest.raises(ValueError, match="rows of 2 configurations"):
        read_table(mixed)
    twice = tmp_path / "twice.csv"
    twice.write_text("\r\n".join([lines[0], lines[1], lines[1], ""]), newline="")
    with pytest.raises(ValueError, match="repeated trial id"):
        read_table(twice)
    other = tmp_path / "other.csv"
    other.write_text(",".join(ROW_COLUMNS) + "\r\n")  # a table of the previous version
    with pytest.raises(ValueError, match="different columns"):
        read_table(other)


def test_resume_refuses_rows_of_another_configuration_even_without_run_json(tmp_path):
    out = tmp_path / "mix"
    run_trials(TINY, CFG, out, workers=1, progress=False, limit=2)
    before = (out / "trials.csv").read_bytes()
    (out / "run.json").unlink()
    gain0 = TrialConfig(image_size=64, timecourse=RemapTimeCourse(peak_gain=0.0))
    with pytest.raises(ValueError, match=r"holds 2 rows of a different design or configuration \(config_hash "
                                         + config_hash(TINY, CFG)) as e:
        run_trials(TINY, gain0, out, workers=1, progress=False)
    assert str(out) in str(e.value) and "another --out folder" in str(e.value)
    assert (out / "trials.csv").read_bytes() == before  # nothing written
    (out / "run.json").write_text("{not json")  # a damaged run.json: the rows still decide
    with pytest.raises(ValueError, match="different design or configuration"):
        run_trials(TINY, gain0, out, workers=1, progress=False)


@pytest.mark.slow
def test_a_second_run_on_the_same_folder_is_refused(tmp_path, capsys):
    from experiments.__main__ import main

    out = tmp_path / "busy"
    with holding("experiments.psychophysics.runner.folder_lock", out, ENV) as holder:
        with pytest.raises(FolderBusyError, match=f"{out} is in use by another run \\(pid {holder.pid}\\)"):
            run_trials(TINY, CFG, out, workers=1, progress=False)
        code = main(["run", "--quick", "--out", str(out), "--no-progress"])
        err = capsys.readouterr().err
        assert code == 1 and f"error: {out} is in use by another run" in err and "Traceback" not in err
        assert not (out / "trials.csv").exists() and not (out / "run.json").exists()
    with folder_lock(out) as o:  # released with its holder; re-entrant within one process
        with folder_lock(o):
            pass


def test_nan_results_fail_the_command_naming_the_trials(tmp_path, capsys):
    from experiments.__main__ import main

    out = tmp_path / "nan"
    code = main(["run", "--out", str(out), "--amplitudes", "20", "--positions", "morrone", "--flash-times=0",
                 "--fovy-deg", "20", "--fovea-deg", "1", "--image-size", "64", "--workers", "1", "--no-progress"])
    err = capsys.readouterr().err
    assert code == 1
    assert "8 of 8 trials produced NaN where a number was expected (trial_id 0, 1, 2, 3, 4, 5, 6, 7;" in err
    assert "perceived_x_deg" in err and len(err.strip().splitlines()) == 1
    assert (out / "trials.csv").exists() and not (out / "summary.txt").exists() and not (out / "fig11.png").exists()


@pytest.mark.slow
def test_workers_use_one_thread_ignore_ctrl_c_and_know_their_parent():
    pool = _make_pool(TrialConfig(image_size=32), 1)
    try:
        st = pool.submit(_worker_status).result(timeout=120)
    finally:
        pool.shutdown()
    assert st["ppid"] == os.getpid() and st["pid"] != os.getpid()
    assert st["sigint"] == signal.SIG_IGN
    assert st["threads"] and all(n == 1 for n in st["threads"].values()), st["threads"]


# ---------------------------------------------------------------------------------------------- signals
from procs import alive as _alive  # noqa: E402  (tests/procs.py)
from procs import children as _children  # noqa: E402


RUN = [sys.executable, "-m", "experiments", "run", "--image-size", "64", "--no-recording", "--no-progress",
       "--workers", "2", "--flash-times=-100:100:10"]


def _start_run(out: Path, capture: bool = True) -> tuple[subprocess.Popen, list[int]]:
    """A 2-worker run in its own session, once both workers have written rows; its children's pids."""
    pipe = subprocess.PIPE if capture else subprocess.DEVNULL  # (orphaned workers would hold a pipe open)
    proc = subprocess.Popen([*RUN, "--out", str(out)], env=ENV, cwd=ROOT, start_new_session=True,
                            stdout=pipe, stderr=pipe, text=True)
    deadline = time.monotonic() + 120
    csv_path = out / "trials.csv"
    while time.monotonic() < deadline and proc.poll() is None:
        if csv_path.exists() and csv_path.read_bytes().count(b"\n") >= 4:
            break
        time.sleep(0.05)
    assert proc.poll() is None, proc.communicate()
    kids = _children(proc.pid)
    assert len(kids) >= 2, kids  # two workers (and multiprocessing's resource tracker)
    return proc, kids


from procs import gone as _gone  # noqa: E402
from procs import holding  # noqa: E402


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.slow
def test_kill_9_of_the_command_leaves_no_workers(tmp_path):
    proc, kids = _start_run(tmp_path / "k9", capture=False)
    try:
        os.kill(proc.pid, signal.SIGKILL)  # the parent only: its workers must notice on their own
        proc.wait(timeout=30)
        assert _gone(kids) == []
    finally:
        for p in kids:
            if _alive(p):
                os.kill(p, signal.SIGKILL)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("sig, group", [(signal.SIGINT, True), (signal.SIGTERM, False)], ids=["ctrl-c", "sigterm"])
@pytest.mark.slow
def test_interrupted_command_stops_its_workers_and_says_how_to_resume(tmp_path, sig, group):
    """Ctrl-C (SIGINT to the whole process group, as a terminal sends it) or SIGTERM to the parent:
    no traceback, workers gone, exit 128 + signal, one line with the command that resumes."""
    out = tmp_path / "int"
    proc, kids = _start_run(out)
    try:
        os.killpg(proc.pid, sig) if group else os.kill(proc.pid, sig)
        _, err = proc.communicate(timeout=60)
        assert proc.returncode == 128 + sig, err
        assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert len(lines) == 1, err
        assert lines[0].startswith(f"python -m experiments run: interrupted ({sig.name}) with ")
        assert f"trials saved in {out / 'trials.csv'}; to resume, run the same command again: " in lines[0]
        assert _gone(kids) == []
    finally:
        for p in kids:
            if _alive(p):
                os.kill(p, signal.SIGKILL)
    # the command shown is the one that was run (options in another order, the same values)
    from experiments.__main__ import build_parser

    shown = lines[0].rpartition("run the same command again: ")[2]
    import shlex

    words = shlex.split(shown)
    assert words[:4] == ["python", "-m", "experiments", "run"]
    parser = build_parser()
    a, b = vars(parser.parse_args(words[3:])), vars(parser.parse_args([*RUN[3:], "--out", str(out)]))
    assert {k: v for k, v in a.items() if k != "func"} == {k: v for k, v in b.items() if k != "func"}
    n = len(read_table(out / "trials.csv", partial=True)["trial_id"])
    assert f"with {n} of 2016 trials saved" in lines[0] and n >= 3


def test_resume_command_round_trips_every_option():
    from experiments.__main__ import build_parser
    from experiments.cli.run import _command

    import shlex

    parser = build_parser()
    argv = ["run", "--out", "my results", "--quick", "--amplitudes", "12.5,20", "--flash-times=-100:100:50",
            "--positions", "fig11", "--repetitions", "2", "--seed", "7", "--peak-time-ms=-12.25", "--rise-ms", "20",
            "--decay-ms", "35", "--peak-gain", "0.5", "--image-size", "128", "--fovy-deg", "80", "--fovea-deg", "1.5",
            "--oversample", "2", "--threshold", "0.25", "--flash-radius-deg", "0.75", "--endpoint-noise", "1e-05",
            "--workers", "1", "--formats", "pdf", "--no-recording", "--no-progress"]
    args = parser.parse_args(argv)
    words = shlex.split(_command(args))
    again = parser.parse_args(words[3:])
    assert {k: v for k, v in vars(again).items() if k != "func"} == {k: v for k, v in vars(args).items() if k != "func"}
    assert _command(parser.parse_args(["run"])) == "python -m experiments run --out results"
    assert np.isclose(again.endpoint_noise, 1e-5)


def test_a_missing_table_is_an_error_not_an_empty_table(tmp_path):
    """A finished table that is not there is a FileNotFoundError naming it (an empty table read from a wrong
    path would make every statistic of it fail later, far from the cause); ``partial=True`` (a run still
    starting) reads it as no rows yet."""
    missing = tmp_path / "nowhere" / "trials.csv"
    with pytest.raises(FileNotFoundError, match="no trials table there"):
        read_table(missing)
    assert len(read_table(missing, partial=True)["trial_id"]) == 0


class _SignalInFinaliser:
    """Sends ``sig`` to the main thread from its ``__del__``: the handler then runs inside the
    finaliser, where a raised exception is printed as "Exception ignored" and lost."""

    def __init__(self, sig: int) -> None:
        self.sig = sig

    def __del__(self) -> None:
        import threading

        signal.pthread_kill(threading.get_ident(), self.sig)
        for _ in range(1000):  # bytecode: the handler runs here, inside the finaliser
            pass


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_caught_in_a_finaliser_still_interrupts(sig):
    """Seen in CI: ``train`` interrupted while numba compiled (llvmlite's finalisers and ctypes
    callbacks) ran on and exited 0. The handler defers such a signal and sends it again."""
    from experiments.folders import Interrupted, interruptible, swallowing_context

    before = signal.getsignal(signal.SIGTERM)  # pytest-xdist's workers may hold Ray's handler
    with pytest.raises(Interrupted) as e:
        with interruptible():
            bomb = _SignalInFinaliser(sig)
            del bomb
            time.sleep(10)  # the re-sent signal interrupts this (within ~20 ms)
    assert e.value.signum == sig
    assert signal.getsignal(signal.SIGTERM) is before  # handlers restored

    class Probe:
        def __del__(self):
            Probe.seen = swallowing_context(sys._getframe())

    Probe()
    assert Probe.seen and not swallowing_context(sys._getframe())


def _c_extension_call(sig: int) -> None:
    """What pybind11 does when a signal's exception is raised while it converts an argument (seen in CI:
    ``train`` sent SIGTERM while the scene's MuJoCo spec was built): the exception is dropped and another
    one, "incompatible function arguments", raised instead."""
    try:
        signal.pthread_kill(threading.get_ident(), sig)
        for _ in range(1000):  # bytecode: the handler runs here
            pass
    except BaseException:
        raise TypeError("add_geom(): incompatible function arguments") from None


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_turned_into_another_error_still_interrupts(sig):
    """The error a C extension made of the signal's ``Interrupted`` leaves the block as that
    ``Interrupted`` (exit 128 + signal, one line), while the same error without a signal is itself."""
    from experiments.folders import Interrupted, interruptible

    with pytest.raises(Interrupted) as e:
        with interruptible():
            _c_extension_call(sig)
    assert e.value.signum == sig and isinstance(e.value.__cause__, TypeError)
    with pytest.raises(TypeError, match="incompatible"):
        with interruptible():
            raise TypeError("add_geom(): incompatible function arguments")


def test_a_signal_deferred_to_the_end_of_the_block_is_raised_there():
    """A deferred signal whose block ends before it is sent again is raised on the way out."""
    from experiments.folders import Interrupted, interruptible

    got = []
    before = signal.signal(signal.SIGTERM, lambda s, f: got.append(s))
    try:
        with pytest.raises(Interrupted):
            with interruptible():
                bomb = _SignalInFinaliser(signal.SIGTERM)
                del bomb
        time.sleep(0.2)  # the re-send timer's 20 ms: it must not reach the restored handler
    finally:
        signal.signal(signal.SIGTERM, before)
    assert got == []
