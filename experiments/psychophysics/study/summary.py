"""The study's summary files: ``summary.txt`` and ``summary.csv``, written atomically through
:mod:`experiments.folders`; for the displacement paradigm, the psychometric fits per blank."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...folders import atomic_write_text, write_csv

__all__ = ["displacement_outputs", "write_summary"]


def write_summary(out: Path, text: str, rows: list[dict]) -> None:
    """``summary.txt`` and ``summary.csv`` (the csv module's CRLF rows, as before), each written atomically."""
    atomic_write_text(out / "summary.txt", text)
    write_csv(out / "summary.csv", list(rows[0]), rows, lineterminator="\r\n")


def displacement_outputs(table, config, out: Path, csv_path: Path, formats) -> dict:
    """Summary (per blank: PSE and threshold of the psychometric function) and its figure; no
    recording (it follows flashes)."""
    from .. import displacement_psychometrics, save_displacement

    fits = displacement_psychometrics(table, n_boot=200)
    rows = [
        {
            "blank_ms": b,
            "pse_deg": round(r["pse_deg"], 3),
            "pse_ci_low": round(r["pse_ci"][0], 3),
            "pse_ci_high": round(r["pse_ci"][1], 3),
            "threshold_deg": round(r["threshold_deg"], 3),
            "threshold_ci_low": round(r["threshold_ci"][0], 3),
            "threshold_ci_high": round(r["threshold_ci"][1], 3),
            "monotonic": r["monotonic"],
            "n_trials": int(np.sum(table["flash_time_ms"] == b)),
        }
        for b, r in fits.items()
    ]
    lines = [
        "Saccadic suppression of displacement (target steps during the saccade; + = forward)",
        f"trials: {len(table['trial_id'])}; model: {config.model}, condition: {config.condition}",
        "blank (ms)   PSE (deg) [95% CI]        threshold (deg) [95% CI]   P(forward) per step "
        + " ".join(f"{s:+g}" for s in next(iter(fits.values()))["steps_deg"]),
    ]
    for b, r in fits.items():
        flag = "" if r["monotonic"] else "   NOT MONOTONIC: the threshold is not meaningful"
        lines.append(
            f"{b:10d}   {r['pse_deg']:+6.2f} [{r['pse_ci'][0]:+6.2f}, {r['pse_ci'][1]:+6.2f}]   "
            f"{r['threshold_deg']:6.2f} [{r['threshold_ci'][0]:6.2f}, {r['threshold_ci'][1]:6.2f}]      "
            + " ".join(f"{p:.2f}" for p in r["p_forward"])
            + flag
        )
    lines.append(
        "CIs: 200 bootstrap resamples of the reports within each step; threshold = s.d. of the cumulative Gaussian"
    )
    text = "\n".join(lines) + "\n"
    write_summary(out, text, rows)
    figures = save_displacement(table, out, formats)
    return {"table": csv_path, "summary": text, "figures": figures, "recording": None}
