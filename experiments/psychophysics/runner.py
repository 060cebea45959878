"""Incremental, resumable, parallel execution of a design: one CSV row per trial as it finishes.

``run_trials`` appends each finished trial to ``trials.csv`` (flushed per batch); on restart it
reads the rows already there, skips those trial ids and runs the rest. The finished table is
rewritten sorted by ``trial_id`` and also saved as Parquet, so a killed-and-resumed run ends with
the same table as an uninterrupted one.

Nothing is silently wrong:

* every row ends with ``config_hash`` (``config_hash``: a hash of the design and configuration,
  ``config_fingerprint``) and ``row_crc32`` (CRC-32 of the row's text before it, 8 hex digits). A
  row torn by an interruption, or damaged later, fails its checksum: a resume drops it and runs
  that trial again (and says so); ``read_table`` refuses a table holding one. A resume refuses rows
  of another configuration, even when ``run.json`` was deleted.
* the output folder is locked (``fcntl.flock`` on ``DIR/.lock``) for the duration of a run: a
  second run on the same folder fails at once with ``FolderBusyError``.

Trials run in worker processes (``spawn`` context: EGL contexts do not survive fork), each reusing
one ``TrialRunner``. Workers die with their parent (Linux ``PR_SET_PDEATHSIG``, and a thread that
watches the parent's pid elsewhere), ignore Ctrl-C (the parent stops them), and use one BLAS/OpenMP
thread each (``threadpoolctl``), as does an in-process run, so that two workers on two cores do not
oversubscribe the machine.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import json
import math
import multiprocessing as mp
import os
import re
import signal
import sys
import threading
import time
import warnings
import zlib
from collections.abc import Callable, Collection, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .backends import check_backend, ray_map
from .bounds import Limit, check_int
from .design import Design, Trial
from .snapshots import write_snapshot
from .trial import ROW_COLUMNS, TEXT_COLUMNS, TrialConfig, TrialRunner

__all__ = [
    "run_trials",
    "read_table",
    "write_parquet",
    "config_fingerprint",
    "config_hash",
    "TABLE_COLUMNS",
    "FolderBusyError",
    "OutputFolderError",
    "prepare_output_folder",
    "folder_lock",
]

#: The columns of ``trials.csv``: the trial's row (``ROW_COLUMNS``), then the integrity columns.
TABLE_COLUMNS = ROW_COLUMNS + TEXT_COLUMNS + ("config_hash", "row_crc32")
_INT_COLUMNS = ("trial_id", "repetition", "seed", "flash_time_ms", "flash_sim_ms")
_LOCK_NAME = ".lock"
_BATCH = Limit(1, 10_000, integer=True)  # run_trials(batch_size=...)
#: ``run_trials(workers=None)`` runs at most this many trials in its own process: a worker process
#: takes ~3 s to start (imports, numba's kernels read back, the head built), more than ~64 trials take.
SMALL_RUN_TRIALS = 64
_LIMIT = Limit(0, 10**9, integer=True)  # run_trials(limit=...)

_WORKER: TrialRunner | None = None


class FolderBusyError(RuntimeError):
    """Another run holds the output folder's lock."""


class OutputFolderError(ValueError):
    """The output folder cannot be used (a file, not creatable, not writable, empty name)."""


# ---------------------------------------------------------------------------------------------- workers
def _limit_threads() -> None:
    """One BLAS/OpenMP/numba thread in this process from now on (a worker: two workers on two cores).
    numba first: under its OpenMP threading layer, changing numba's thread count also sets OpenMP's."""
    import numba
    from threadpoolctl import threadpool_limits

    numba.set_num_threads(1)
    threadpool_limits(limits=1)


@contextlib.contextmanager
def _one_thread() -> Iterator[None]:
    """One BLAS/OpenMP/numba thread while the block runs (in-process trials), each restored after.
    numba's count is set to 1 too: else the saccade kernels, which set numba's thread count for their
    loops and restore it, would restore OpenMP's count along with it (numba's OpenMP threading layer)."""
    import numba
    from threadpoolctl import threadpool_limits

    prev = numba.get_num_threads()  # first: numba's first call starts its OpenMP pool at every core
    with threadpool_limits(limits=1):
        numba.set_num_threads(1)
        try:
            yield
        finally:
            numba.set_num_threads(prev)


def _die_with_parent(parent_pid: int) -> None:
    """Make this worker exit when ``parent_pid`` dies, even by SIGKILL (``folders.die_with_parent``)."""
    from ..folders import die_with_parent

    die_with_parent(parent_pid)


def _init_worker(config: TrialConfig, parent_pid: int | None = None) -> None:
    global _WORKER
    if parent_pid is not None:  # a local pool's worker (a Ray actor is stopped by the driver, ray_map)
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole process group: the parent stops us
        _die_with_parent(parent_pid)
    _WORKER = TrialRunner(config)
    _limit_threads()  # after TrialRunner: every BLAS/OpenMP library it loads is limited


def _run_one(runner: TrialRunner, trial: Trial, snap: tuple | None) -> tuple[dict, dict | None]:
    """A trial's row, and its snapshot when ``snap`` = (design, config hash, example ids) names it."""
    row = runner.run(trial)
    if snap is None or trial.trial_id not in snap[2]:
        return row, None
    from .snapshots import take_snapshot

    return row, take_snapshot(runner, trial, row, snap[0], snap[1])


def _run_batch(trials: list[Trial], snap: tuple | None = None) -> list[tuple[dict, dict | None]]:
    assert _WORKER is not None
    return [_run_one(_WORKER, t, snap) for t in trials]


def _worker_status() -> dict:
    """Diagnostics of a worker process (tests): pid, parent pid and its thread-pool sizes."""
    from threadpoolctl import threadpool_info

    return {
        "pid": os.getpid(),
        "ppid": os.getppid(),
        "sigint": signal.getsignal(signal.SIGINT),
        "threads": {i["internal_api"]: i["num_threads"] for i in threadpool_info()},
    }


@contextlib.contextmanager
def _sigint_ignored() -> Iterator[None]:
    """SIGINT ignored while worker processes are started: they inherit the disposition, so a Ctrl-C
    during their start-up (imports) cannot print their tracebacks."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


def _make_pool(config: TrialConfig, workers: int) -> ProcessPoolExecutor:
    return ProcessPoolExecutor(
        max_workers=int(workers),
        mp_context=mp.get_context("spawn"),
        initializer=_init_worker,
        initargs=(config, os.getpid()),
    )


def _stop_pool(pool: ProcessPoolExecutor) -> None:
    """Cancel what is pending and end the workers now (after an interruption or an error)."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        with contextlib.suppress(Exception):
            p.terminate()
    deadline = time.monotonic() + 5.0
    for p in procs:
        with contextlib.suppress(Exception):
            p.join(max(0.0, deadline - time.monotonic()))
            if p.is_alive():
                p.kill()
                p.join(1.0)
    # let the pool's manager thread finish (it closes its wake-up pipe): one still closing it when the
    # interpreter exits races concurrent.futures' exit hook, which then writes to the closed pipe and
    # prints "Exception ignored ... Bad file descriptor" under the one-line interruption message
    manager = getattr(pool, "_executor_manager_thread", None)
    if manager is not None:
        with contextlib.suppress(Exception):
            manager.join(max(1.0, deadline - time.monotonic()))


# ---------------------------------------------------------------------------------------------- folder
def prepare_output_folder(out_dir: str | os.PathLike) -> Path:
    """Create ``out_dir`` if needed and check that it is a writable folder; ``OutputFolderError`` else."""
    if isinstance(out_dir, (bytes, bytearray)) or not isinstance(out_dir, (str, os.PathLike)):
        raise TypeError(f"the output folder must be a path; got {out_dir!r}")
    text = os.fspath(out_dir)
    if not str(text).strip():
        raise OutputFolderError("the output folder name is empty")
    if "\x00" in str(text):
        raise OutputFolderError(f"the output folder name {text!r} contains a NUL character")
    out = Path(text)
    if out.exists() and not out.is_dir():
        raise OutputFolderError(f"{out} is a file, not a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise OutputFolderError(f"{out} is a file, not a folder") from None
    except OSError as e:
        raise OutputFolderError(f"cannot create the folder {out}: {e.strerror or e}") from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise OutputFolderError(f"cannot write in the folder {out}: permission denied")
    return out


_HELD: dict[str, list] = {}  # resolved folder -> [fd, depth]: the locks this process holds
_HELD_LOCK = threading.Lock()


@contextlib.contextmanager
def folder_lock(out_dir: str | os.PathLike) -> Iterator[Path]:
    """Hold an exclusive lock on the folder (``DIR/.lock``) while the block runs; re-entrant within
    a process. Another process holding it raises ``FolderBusyError`` at once (no waiting)."""
    out = prepare_output_folder(out_dir)
    key = str(out.resolve())
    with _HELD_LOCK:
        held = _HELD.get(key)
        if held is not None:
            held[1] += 1
    if held is not None:
        try:
            yield out
        finally:
            with _HELD_LOCK:
                held[1] -= 1
        return
    from ..folders import LockBusyError, path_lock

    try:
        lock = path_lock(out / _LOCK_NAME, str(out))
        lock.__enter__()
    except LockBusyError as e:
        raise FolderBusyError(str(e)) from None
    except OSError as e:
        raise OutputFolderError(f"cannot write in the folder {out}: {e.strerror or e}") from None
    try:
        with _HELD_LOCK:
            _HELD[key] = [None, 1]
        yield out
    finally:
        with _HELD_LOCK:
            _HELD.pop(key, None)
        lock.__exit__(None, None, None)


# ---------------------------------------------------------------------------------------------- table
def config_fingerprint(design: Design, config: TrialConfig) -> dict:
    """What must match for a resumed run to continue an earlier one."""
    tc = config.timecourse
    cfg = {f.name: getattr(config, f.name) for f in dataclasses.fields(config) if f.name != "timecourse"}
    cfg["disabled"] = list(cfg["disabled"])
    cfg["markers"] = [list(m) for m in cfg["markers"]]
    cfg["observer"] = dataclasses.asdict(config.observer)
    cfg["population"] = dataclasses.asdict(config.population)
    if config.generator is None:
        del cfg["generator"]  # the defaults: fingerprints (and config hashes) of earlier runs stay valid
    else:
        cfg["generator"] = dataclasses.asdict(config.generator)
    cfg.update(peak_time_ms=tc.peak_time_ms, rise_ms=tc.rise_ms, decay_ms=tc.decay_ms, peak_gain=tc.peak_gain)
    return {"design": design.to_dict(), "config": cfg}


def config_hash(design: Design, config: TrialConfig) -> str:
    """12 hex digits identifying the design and configuration (a hash of ``config_fingerprint``)."""
    text = json.dumps(config_fingerprint(design, config), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def _format(v: float) -> str:
    return repr(float(v)) if not float(v).is_integer() else str(int(v))


def _header() -> str:
    return ",".join(TABLE_COLUMNS) + "\r\n"


def _text(v) -> str:
    if not isinstance(v, str) or not re.fullmatch(r"[a-z_]+", v):
        raise ValueError(f"a text column must be a lower-case name; got {v!r:.60}")
    return v


def _line(row: dict, chash: str) -> str:
    body = ",".join([_format(row[c]) for c in ROW_COLUMNS] + [_text(row[c]) for c in TEXT_COLUMNS] + [chash])
    return f"{body},{zlib.crc32(body.encode()):08x}\r\n"


@dataclass
class _Scan:
    rows: dict[int, dict] = field(default_factory=dict)  # trial_id -> values (+ "config_hash")
    bad: list[tuple[int, str]] = field(default_factory=list)  # (line number, reason)
    duplicates: list[int] = field(default_factory=list)  # line numbers repeating a trial id

    def problems(self, limit: int = 3) -> str:
        items = [f"line {n}: {why}" for n, why in self.bad[:limit]]
        more = len(self.bad) - limit
        return "; ".join(items) + (f"; and {more} more" if more > 0 else "")


def _parse_line(line: str) -> tuple[dict | None, str]:
    """A row's values, or None and why not (torn, checksum mismatch, unreadable)."""
    body, sep, crc = line.rpartition(",")
    if not sep or len(crc) != 8 or any(ch not in "0123456789abcdef" for ch in crc):
        return None, "torn or damaged (no checksum at the end)"
    if zlib.crc32(body.encode("utf-8", "surrogateescape")) != int(crc, 16):
        return None, "checksum mismatch (torn or damaged row)"
    fields = body.split(",")
    if len(fields) != len(TABLE_COLUMNS) - 1:
        return None, f"{len(fields) + 1} fields instead of {len(TABLE_COLUMNS)}"
    try:
        nums = {c: float(v) for c, v in zip(ROW_COLUMNS, fields)}
    except ValueError:
        return None, "a value is not a number"
    texts = fields[len(ROW_COLUMNS) : len(ROW_COLUMNS) + len(TEXT_COLUMNS)]
    if not all(re.fullmatch(r"[a-z_]+", t) for t in texts):
        return None, "a text column is not a name"
    vals: dict[str, float | str] = dict(nums)
    vals.update(zip(TEXT_COLUMNS, texts))
    if not all(nums[c].is_integer() for c in _INT_COLUMNS):  # _INT_COLUMNS are numeric (ROW_COLUMNS)
        return None, "a whole-number column holds a fraction"
    vals["config_hash"] = fields[-1]
    return vals, ""


def _scan(path: Path) -> _Scan:
    """Read and verify every row of a trials CSV (the header must be this version's)."""
    scan = _Scan()
    if not path.exists():
        return scan
    with path.open("r", encoding="utf-8", errors="surrogateescape", newline="") as fh:
        text = fh.read()
    if not text:
        return scan  # created but killed before the header: an empty table
    lines = text.split("\n")
    header = lines[0].rstrip("\r")
    if header != ",".join(TABLE_COLUMNS):
        raise ValueError(
            f"{path} has different columns than this version writes (it may come from an older "
            "version, or be damaged); use a new --out folder"
        )
    last = len(lines) - 1
    for i, raw in enumerate(lines[1:], start=2):
        line = raw.rstrip("\r")
        if not line and i - 1 == last:
            continue  # the newline ending the last row
        vals, why = _parse_line(line)
        if vals is None:
            scan.bad.append((i, why if line else "an empty line"))
            continue
        tid = int(vals["trial_id"])
        if tid in scan.rows:
            scan.duplicates.append(i)
        scan.rows[tid] = vals
    return scan


def read_table(path: str | os.PathLike, *, partial: bool = False) -> dict[str, np.ndarray]:
    """Read a trials CSV into columns: numpy float arrays for ``ROW_COLUMNS``, string arrays for
    ``TEXT_COLUMNS`` (model, condition, paradigm) and ``config_hash``, sorted by ``trial_id``.

    Every row's checksum is verified. By default (a finished table) a torn or damaged row, a repeated
    trial id or rows of more than one configuration raise ``ValueError`` naming the file and the lines
    (running the same study command again redoes the damaged trials). ``partial=True`` reads a table
    that is still being written or was interrupted: such rows are skipped with a ``RuntimeWarning``.
    """
    path = Path(path)
    if not partial and not path.is_file():
        raise FileNotFoundError(
            f"{path}: no trials table there; run the study first (python -m experiments run --out FOLDER), "
            "or read a table still being written with partial=True"
        )
    scan = _scan(path)
    if scan.bad or scan.duplicates or len({r["config_hash"] for r in scan.rows.values()}) > 1:
        what = []
        if scan.bad:
            what.append(f"{len(scan.bad)} torn or damaged row(s) ({scan.problems()})")
        if scan.duplicates:
            lines = ", ".join(map(str, scan.duplicates[:3]))
            what.append(f"{len(scan.duplicates)} repeated trial id(s) (lines {lines})")
        hashes = sorted({r["config_hash"] for r in scan.rows.values()})
        if len(hashes) > 1:
            what.append(f"rows of {len(hashes)} configurations (config_hash {', '.join(hashes)})")
        msg = f"{path}: " + "; ".join(what)
        if not partial:
            raise ValueError(
                msg + ". Run the same study command again to redo the damaged trials, or read it "
                "with partial=True to skip them"
            )
        warnings.warn(msg + "; skipped", RuntimeWarning, stacklevel=2)
    rows = [scan.rows[k] for k in sorted(scan.rows)]
    table = {c: np.array([r[c] for r in rows], dtype=float) for c in ROW_COLUMNS}
    for c in TEXT_COLUMNS:
        table[c] = np.array([r[c] for r in rows], dtype=str)
    table["config_hash"] = np.array([r["config_hash"] for r in rows], dtype=str)
    return table


def _write_sorted(path: Path, rows: list[dict], chash: str) -> None:
    from ..folders import atomic_write_text

    atomic_write_text(path, _header() + "".join(_line(r, chash) for r in sorted(rows, key=lambda r: r["trial_id"])))


def write_parquet(csv_path: str | os.PathLike, parquet_path: str | os.PathLike) -> None:
    """The CSV table (verified) as Parquet: the same columns with ids and times as integers, and
    ``config_hash``; Parquet's own page checksums replace ``row_crc32``. Written atomically."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    t = read_table(csv_path)
    cols = {c: (t[c].astype(np.int64) if c in _INT_COLUMNS else t[c]) for c in ROW_COLUMNS}
    for c in TEXT_COLUMNS:
        cols[c] = pa.array(t[c].tolist(), type=pa.string())
    cols["config_hash"] = pa.array(t["config_hash"].tolist(), type=pa.string())
    from ..folders import atomic_write_bytes

    sink = pa.BufferOutputStream()
    pq.write_table(pa.table(cols), sink, write_page_checksum=True)
    atomic_write_bytes(parquet_path, sink.getvalue().to_pybytes())


def _lost_snapshots(out: Path, rows: dict, examples: frozenset, chash: str) -> list[int]:
    """Finished example trials whose snapshot is missing, unreadable or of another run."""
    from .snapshots import SnapshotError, read_snapshot

    lost = []
    for i in sorted(examples & set(rows)):
        try:
            read_snapshot(out, i, chash)
        except SnapshotError:
            lost.append(i)
    return lost


def _batches(trials: list[Trial], size: int) -> Iterable[list[Trial]]:
    for i in range(0, len(trials), size):
        yield trials[i : i + size]


def _check_resume(out: Path, csv_path: Path, meta_path: Path, fp: dict, chash: str) -> _Scan:
    """The verified rows of an earlier run in ``out``; ValueError if they belong to another one."""
    if meta_path.exists() and csv_path.exists():
        try:
            old = json.loads(meta_path.read_text())
        except (ValueError, OSError):
            old = None  # damaged: the rows' config_hash decides below
        if old is not None and {k: old.get(k) for k in ("design", "config")} != json.loads(json.dumps(fp)):
            raise ValueError(
                f"{out} holds a run with a different design or configuration; use another --out folder or delete it"
            )
    scan = _scan(csv_path)
    foreign = sorted({r["config_hash"] for r in scan.rows.values()} - {chash})
    if foreign:
        n = sum(r["config_hash"] != chash for r in scan.rows.values())
        raise ValueError(
            f"{csv_path} holds {n} rows of a different design or configuration (config_hash "
            f"{', '.join(foreign)}; this run: {chash}); use another --out folder, or delete "
            f"{csv_path} to start over"
        )
    return scan


def run_trials(
    design: Design,
    config: TrialConfig,
    out_dir: str | os.PathLike,
    *,
    workers: int | None = 2,
    progress: bool = True,
    batch_size: int = 8,
    limit: int | None = None,
    on_row: Callable[[dict], None] | None = None,
    examples: Collection[int] = (),
    backend: str = "local",
    ray_address: str | None = None,
) -> Path:
    """Run every trial of ``design`` not yet in ``out_dir/trials.csv``; returns the CSV path.

    workers : processes or Ray actors (1 = in this process); None: 2, or 1 where at most
    ``SMALL_RUN_TRIALS`` trials are left to do (starting a worker costs more than they take). backend : ``local`` (processes) or ``ray``
    (actors; a local instance, or the cluster at ``ray_address``: ``backends.ray_map``). limit : stop after this many new trials (for
    tests of resumption; the table is then left unsorted/partial, as after an interruption).
    A ``run.json`` beside the table records the design and configuration and every row carries its
    ``config_hash``: resuming with a different one raises ``ValueError``. Torn or damaged rows are
    dropped (with a note on stderr) and their trials run again. The folder is locked while this
    runs (``FolderBusyError`` if another run holds it); an unusable folder raises
    ``OutputFolderError``. On an interruption (KeyboardInterrupt) or an error the workers are
    stopped and the rows written so far stay, ready to be resumed.

    examples : trial ids whose snapshot (``snapshots``: frames, retinal maps, scene, eye trace) is
    written to ``out_dir/examples/`` before their row; a finished example whose snapshot is missing or
    unreadable is run again (localization and separation paradigms).
    """
    if not isinstance(design, Design):
        raise TypeError(f"design must be a Design; got {design!r}")
    if not isinstance(config, TrialConfig):
        raise TypeError(f"config must be a TrialConfig; got {config!r}")
    workers = None if workers is None else check_int("workers", workers)
    check_backend(backend, ray_address)
    batch_size = check_int("batch_size", batch_size, _BATCH)
    if limit is not None:
        limit = check_int("limit", limit, _LIMIT)
    examples = frozenset(check_int("each of examples", i, _LIMIT) for i in examples)
    if examples and config.paradigm == "displacement":
        raise ValueError(
            "examples (snapshots for the recording) exist for the localization and separation paradigms only"
        )
    with folder_lock(out_dir) as out:
        return _run_locked(
            design, config, out, workers, progress, batch_size, limit, on_row, examples, backend, ray_address
        )


def _run_locked(
    design: Design,
    config: TrialConfig,
    out: Path,
    workers: int | None,
    progress: bool,
    batch_size: int,
    limit: int | None,
    on_row: Callable[[dict], None] | None,
    examples: frozenset = frozenset(),
    backend: str = "local",
    ray_address: str | None = None,
) -> Path:
    csv_path, meta_path = out / "trials.csv", out / "run.json"
    fp = config_fingerprint(design, config)
    chash = config_hash(design, config)
    scan = _check_resume(out, csv_path, meta_path, fp, chash)
    if scan.bad or scan.duplicates:
        n = len(scan.bad)
        print(
            f"{csv_path}: dropped {n} torn or damaged row(s) ({scan.problems()}); their trials are run again"
            if n
            else f"{csv_path}: dropped {len(scan.duplicates)} repeated row(s)",
            file=sys.stderr,
        )
    from ..folders import atomic_write_text

    atomic_write_text(meta_path, json.dumps({**fp, "config_hash": chash}, indent=1))
    lost = _lost_snapshots(out, scan.rows, examples, chash)
    if lost:
        print(
            f"{out / 'examples'}: {len(lost)} example trial(s) without a readable snapshot (trial_id "
            f"{', '.join(map(str, lost[:6]))}{', ...' if len(lost) > 6 else ''}); they are run again",
            file=sys.stderr,
        )
    done = [scan.rows[k] for k in sorted(scan.rows) if k not in lost]
    done_ids = set(scan.rows) - set(lost)
    todo = [t for t in design.trials() if t.trial_id not in done_ids]
    if limit is not None:
        todo = todo[:limit]
    if workers is None:
        workers = 1 if backend == "local" and len(todo) <= SMALL_RUN_TRIALS else 2
    _write_sorted(csv_path, done, chash)  # drop torn lines before appending
    bar = None
    if progress and todo:
        from ..cli.progress import Progress

        bar = Progress(design.n_trials, initial=len(done), unit="trial", desc="flash trials")
    try:
        with csv_path.open("a", newline="") as fh:
            snap = (design, chash, examples) if examples else None

            def emit(results: list[tuple[dict, dict | None]]) -> None:
                rows = [r for r, _ in results]
                for r, snapshot in results:
                    if snapshot is not None:  # before its row: a row implies its snapshot
                        write_snapshot(out, snapshot)
                    fh.write(_line(r, chash))
                    done.append(r)
                    if on_row is not None:
                        on_row(r)
                fh.flush()
                if bar is not None:
                    bar.update(len(rows))

            if backend == "ray" and todo:
                size = max(1, min(batch_size, math.ceil(len(todo) / (4 * workers))))
                batches = list(_batches(todo, size))
                ray_map(
                    _init_worker,
                    (config,),
                    functools.partial(_run_batch, snap=snap),
                    batches,
                    lambda k, results: emit(results),
                    workers=workers,
                    address=ray_address,
                )
            elif workers == 1 or len(todo) <= batch_size:
                with _one_thread():
                    runner = TrialRunner(config)
                    try:
                        for b in _batches(todo, batch_size):
                            emit([_run_one(runner, t, snap) for t in b])
                    finally:
                        runner.close()
            elif todo:
                size = max(1, min(batch_size, math.ceil(len(todo) / (4 * workers))))
                pool = _make_pool(config, workers)
                try:
                    with _sigint_ignored():  # the workers start while submitting; they inherit SIG_IGN
                        futures = [pool.submit(_run_batch, b, snap) for b in _batches(todo, size)]
                    for f in as_completed(futures):
                        emit(f.result())
                except BaseException:
                    _stop_pool(pool)
                    raise
                pool.shutdown(wait=True)
    finally:
        if bar is not None:
            bar.close()
    if limit is None or len(done) == design.n_trials:
        _write_sorted(csv_path, done, chash)
        write_parquet(csv_path, out / "trials.parquet")
    return csv_path
