"""Incremental, resumable, parallel execution of a design: one CSV row per trial as it finishes.

``run_trials`` appends each finished trial to ``trials.csv`` (flushed per row); on restart it
reads the rows already there (dropping a torn last line), skips those trial ids and runs the
rest. The finished table is rewritten sorted by ``trial_id`` and also saved as Parquet, so a
killed-and-resumed run ends with the same table as an uninterrupted one. Trials run in worker
processes (``spawn`` context: EGL contexts do not survive fork), each reusing one
``TrialRunner``.
"""

from __future__ import annotations

import csv
import json
import math
import multiprocessing as mp
import os
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Callable, Iterable

import numpy as np

from .design import Design, Trial
from .trial import ROW_COLUMNS, TrialConfig, TrialRunner

__all__ = ["run_trials", "read_table", "write_parquet", "config_fingerprint"]

_WORKER: TrialRunner | None = None


def _init_worker(config: TrialConfig) -> None:
    global _WORKER
    _WORKER = TrialRunner(config)


def _run_batch(trials: list[Trial]) -> list[dict]:
    assert _WORKER is not None
    return [_WORKER.run(t) for t in trials]


def read_table(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Read a trials CSV into columns (numpy arrays), skipping incomplete or malformed rows."""
    rows = _read_rows(Path(path))
    return {c: np.array([r[c] for r in rows], dtype=float) for c in ROW_COLUMNS}


def _read_rows(path: Path) -> list[dict]:
    if not path.exists():
        return []
    out: dict[int, dict] = {}
    with path.open(newline="") as fh:
        reader = csv.DictReader(fh)
        if reader.fieldnames is None or list(reader.fieldnames) != list(ROW_COLUMNS):
            if reader.fieldnames is None:
                return []
            raise ValueError(f"{path} has different columns than this version writes; use a new --out folder")
        for r in reader:
            try:
                vals = {c: float(r[c]) for c in ROW_COLUMNS}
            except (TypeError, ValueError):
                continue  # a line torn by an interruption
            out[int(vals["trial_id"])] = vals
    return [out[k] for k in sorted(out)]


def config_fingerprint(design: Design, config: TrialConfig) -> dict:
    """What must match for a resumed run to continue an earlier one."""
    tc = config.timecourse
    return {"design": design.to_dict(), "config": {
        "image_size": config.image_size, "fovy_deg": config.fovy_deg, "fovea_deg": config.fovea_deg,
        "threshold": config.threshold, "endpoint_noise": config.endpoint_noise, "oversample": config.oversample,
        "flash_radius_deg": config.flash_radius_deg, "peak_time_ms": tc.peak_time_ms, "rise_ms": tc.rise_ms,
        "decay_ms": tc.decay_ms, "peak_gain": tc.peak_gain}}


def _format(v: float) -> str:
    return repr(float(v)) if not float(v).is_integer() else str(int(v))


def _write_sorted(path: Path, rows: list[dict]) -> None:
    tmp = path.with_suffix(".csv.tmp")
    with tmp.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(ROW_COLUMNS)
        for r in sorted(rows, key=lambda r: r["trial_id"]):
            w.writerow([_format(r[c]) for c in ROW_COLUMNS])
    tmp.replace(path)


def write_parquet(csv_path: str | os.PathLike, parquet_path: str | os.PathLike) -> None:
    """The CSV table as Parquet (same columns; ids and times as integers)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    t = read_table(csv_path)
    ints = {"trial_id", "repetition", "seed", "flash_time_ms", "flash_sim_ms"}
    cols = {c: (t[c].astype(np.int64) if c in ints else t[c]) for c in ROW_COLUMNS}
    pq.write_table(pa.table(cols), parquet_path)


def _batches(trials: list[Trial], size: int) -> Iterable[list[Trial]]:
    for i in range(0, len(trials), size):
        yield trials[i:i + size]


def run_trials(
    design: Design,
    config: TrialConfig,
    out_dir: str | os.PathLike,
    *,
    workers: int = 2,
    progress: bool = True,
    batch_size: int = 8,
    limit: int | None = None,
    on_row: Callable[[dict], None] | None = None,
) -> Path:
    """Run every trial of ``design`` not yet in ``out_dir/trials.csv``; returns the CSV path.

    workers : processes (1 = in this process). limit : stop after this many new trials (for
    tests of resumption; the table is then left unsorted/partial, as after an interruption).
    A ``run.json`` beside the table records the design and configuration; resuming with a
    different one raises ``ValueError``.
    """
    if int(workers) != workers or workers < 1:
        raise ValueError(f"workers must be a positive integer; got {workers!r}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    csv_path, meta_path = out / "trials.csv", out / "run.json"
    fp = config_fingerprint(design, config)
    if meta_path.exists() and csv_path.exists():
        old = json.loads(meta_path.read_text())
        if old != json.loads(json.dumps(fp)):
            raise ValueError(f"{out} holds a run with a different design or configuration; use another --out "
                             "folder or delete it")
    meta_path.write_text(json.dumps(fp, indent=1))
    done = _read_rows(csv_path)
    done_ids = {int(r["trial_id"]) for r in done}
    todo = [t for t in design.trials() if t.trial_id not in done_ids]
    if limit is not None:
        todo = todo[: int(limit)]
    _write_sorted(csv_path, done)  # drop any torn line before appending
    bar = None
    if progress and todo:
        from tqdm import tqdm

        bar = tqdm(total=design.n_trials, initial=len(done), unit="trial", desc="flash trials")
    with csv_path.open("a", newline="") as fh:
        writer = csv.writer(fh)

        def emit(rows: list[dict]) -> None:
            for r in rows:
                writer.writerow([_format(r[c]) for c in ROW_COLUMNS])
                done.append(r)
                if on_row is not None:
                    on_row(r)
            fh.flush()
            if bar is not None:
                bar.update(len(rows))

        if workers == 1 or len(todo) <= batch_size:
            runner = TrialRunner(config)
            try:
                for b in _batches(todo, batch_size):
                    emit([runner.run(t) for t in b])
            finally:
                runner.close()
        else:
            size = max(1, min(batch_size, math.ceil(len(todo) / (4 * workers))))
            with ProcessPoolExecutor(max_workers=int(workers), mp_context=mp.get_context("spawn"),
                                     initializer=_init_worker, initargs=(config,)) as pool:
                futures = [pool.submit(_run_batch, b) for b in _batches(todo, size)]
                for f in as_completed(futures):
                    emit(f.result())
    if bar is not None:
        bar.close()
    if limit is None or len(done) == design.n_trials:
        _write_sorted(csv_path, done)
        write_parquet(csv_path, out / "trials.parquet")
    return csv_path
