"""Run (or resume) a study's design into its folder, then write its summary, figures and recording."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .recorder import record_study
from .summary import displacement_outputs, write_summary

__all__ = ["NonFiniteResultError", "run_study"]


class NonFiniteResultError(RuntimeError):
    """Trials produced NaN (or inf) where a number was expected."""


def check_finite(table: dict, csv_path: Path) -> None:
    """``NonFiniteResultError`` naming the trials and columns where a number was expected and NaN
    (or inf) was written."""
    from ..trial import OPTIONAL_COLUMNS, ROW_COLUMNS

    bad = np.zeros(len(table["trial_id"]), bool)
    cols = []
    for c in ROW_COLUMNS:
        paradigm = str(table["paradigm"][0]) if len(table["paradigm"]) else ""
        if any(c in cols_ and p != paradigm for p, cols_ in OPTIONAL_COLUMNS.items()):
            continue  # NaN by design: a column of another paradigm
        m = ~np.isfinite(table[c])
        if m.any():
            cols.append(c)
            bad |= m
    if not bad.any():
        return
    ids = [int(i) for i in table["trial_id"][bad]]
    shown = ", ".join(map(str, ids[:12])) + (f", ... ({len(ids) - 12} more)" if len(ids) > 12 else "")
    raise NonFiniteResultError(
        f"{len(ids)} of {len(bad)} trials produced NaN where a number was expected (trial_id {shown}; columns "
        f"{', '.join(cols[:4])}{', ...' if len(cols) > 4 else ''}): the read-out found no flash activity (e.g. a large "
        f"--peak-gain shifts flashes off the map; a small --image-size or --fovy-deg loses them); the table is in "
        f"{csv_path}, no summary, figures or recording were written"
    )


def run_study(
    design,
    config,
    out: Path,
    *,
    workers: int | None = 2,
    progress: bool = True,
    formats: tuple[str, ...] = ("png", "svg"),
    recording: bool = True,
    backend: str = "local",
    ray_address: str | None = None,
) -> dict:
    """Run (or resume) the design, then write summary, figures and the recording into ``out``
    (the trials on ``workers`` local processes or Ray actors: ``runner.run_trials``' ``backend``).

    The folder is locked for the whole run (``FolderBusyError`` if another run holds it); trials that
    produced NaN where a number was expected raise ``NonFiniteResultError`` after the table is written.
    """
    from ...cli.progress import stage
    from .. import format_summary, read_table, run_trials, save_all, summary
    from ..runner import folder_lock
    from ..snapshots import example_trials

    keep = [t.trial_id for t in example_trials(design)] if recording and config.paradigm != "displacement" else []
    with folder_lock(out) as out:
        csv_path = run_trials(
            design,
            config,
            out,
            workers=workers,
            progress=progress,
            examples=keep,
            backend=backend,
            ray_address=ray_address,
        )
        table = read_table(csv_path)
        check_finite(table, csv_path)
        if config.paradigm == "displacement":
            return displacement_outputs(table, config, out, csv_path, formats)
        rows = summary(table)
        text = format_summary(rows, n_trials=len(table["trial_id"]), config=config)
        write_summary(out, text, rows)
        # only the paper model has a set time course to draw; the others show their own results alone
        stage(f"writing the summary and figures ({', '.join(formats)}) in {out}", enabled=progress)
        figures = save_all(table, out, config.timecourse if config.model == "paper" else None, formats)
        if recording:
            stage(f"writing the Rerun recording {out / 'study.rrd'}", enabled=progress)
        rrd = record_study(out, table, design, config) if recording else None
    return {"table": csv_path, "summary": text, "figures": figures, "recording": rrd}
