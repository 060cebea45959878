"""The ``observer`` against its one timing constant: each value of ``temporal_sd_ms`` with the prior set
again to its calibration target, and the scoreboard's time-course, dark-shift, anisotropy and
separation statistics there.

``observer.prior_sd_deg`` is calibrated on Morrone, Ross & Burr 1997's ~50 % peak compression
(``TARGET_PEAK``). A calibration holds only for the other constants it was made with, so a sweep of
the timing s.d. that kept the prior would measure the stale prior's effect too (it did once: the
docs' "no timing s.d. gives both the width and the forward dark shift" was a 4 deg prior set at
40 ms and kept at 21). :func:`calibrated_prior` finds, for one timing s.d., the prior whose peak
index is ``TARGET_PEAK`` (bisection on log prior_sd: the peak falls as the prior widens);
:func:`sweep` then reads the scoreboard's designs out at it (``phenomena.ROWS``' definitions, the
participant's report noise as the scoreboard adds it), each statistic with a 95 % CI from ``BOOT``
resamples of the trials within their design cells (``phenomena.resample_cells``). Nothing here sets a constant of the model:
the table says what the theory gives where, and which timing s.d. would need a source.

``python -m experiments.psychophysics.timing_sweep --phenomena DIR --out FILE.csv`` reads the
observations a ``phenomena --out DIR`` run cached (or makes them there: 256 px, ~15 min for the three
designs from nothing), prints the table and writes the CSV the docs' table is rendered from
(``experiments/data/observer_timing.csv``, ``markdown_table``; docs/psychophysics/theories.md).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import math
import sys
from pathlib import Path

import numpy as np

__all__ = [
    "TARGET_PEAK",
    "STATS",
    "COLUMNS",
    "BOOT",
    "TIMING_CSV",
    "calibrated_prior",
    "sweep",
    "markdown_table",
    "read_rows",
    "main",
]

#: The calibration target of ``observer.prior_sd_deg``: the peak index of Morrone, Ross & Burr 1997's
#: ~50 % compression (the middle of the scoreboard's 0.35-0.65 range).
TARGET_PEAK = 0.5
#: The statistics read out at each timing s.d. (``phenomena.ROWS``' definitions).
STATS = (
    "peak",
    "peak_time_ms",
    "onset_ms",
    "fwhm_ms",
    "dark_presaccadic_deg",
    "dark_reversal_deg",
    "along_minus_across",
    "separation_ratio",
)
#: The columns of the sweep's CSV: each statistic with its 95 % bootstrap CI.
COLUMNS = ("temporal_sd_ms", "prior_sd_deg") + tuple(f"{k}{s}" for k in STATS for s in ("", "_ci_low", "_ci_high"))
#: Bootstrap replicates of each row (the scoreboard's resampling of the trials within their cells).
BOOT = 500
#: The committed sweep (256 px, the scoreboard's observations).
TIMING_CSV = Path(__file__).resolve().parents[1] / "data" / "observer_timing.csv"
#: The scoreboard's designs the sweep reads out.
DESIGNS = ("references", "dark", "separation")


def calibrated_prior(peak_at, lo: float = 2.0, hi: float = 50.0, tol: float = 0.005, steps: int = 30) -> float:
    """The prior s.d. (deg) whose peak index ``peak_at(prior_sd)`` is ``TARGET_PEAK`` within ``tol``,
    by bisection on log(prior_sd) in [lo, hi] (``peak_at`` must fall as the prior widens). ValueError
    when the target is not bracketed or not reached in ``steps`` halvings."""
    f_lo, f_hi = peak_at(lo) - TARGET_PEAK, peak_at(hi) - TARGET_PEAK
    if not (f_lo > 0 > f_hi):  # (False for NaN too)
        raise ValueError(
            f"the peak index {TARGET_PEAK} is not bracketed by prior s.d. {lo:g} and {hi:g} deg "
            f"(peaks {f_lo + TARGET_PEAK:.3f} and {f_hi + TARGET_PEAK:.3f})"
        )
    a, b = math.log(lo), math.log(hi)
    for _ in range(steps):
        mid = 0.5 * (a + b)
        f = peak_at(math.exp(mid)) - TARGET_PEAK
        if abs(f) <= tol:
            return math.exp(mid)
        a, b = (mid, b) if f > 0 else (a, mid)
    raise ValueError(f"no prior s.d. gives the peak index {TARGET_PEAK} within {tol} in {steps} halvings")


def _readers(folder: Path, image_size: int, quick: bool, progress: bool):
    """design -> function(ObserverParams) -> that design's table with the participant's report noise."""
    from ..modelfit.observe import observe_trials
    from . import TrialConfig, TrialRunner
    from .participant import PARTICIPANT, add_report_noise
    from .phenomena import _columns, _designs

    designs = _designs(quick)
    out = {}
    for name in DESIGNS:
        design, kw = designs[name]
        base = TrialConfig(image_size=image_size, endpoint_noise=PARTICIPANT.endpoint_noise, **kw)
        runner = TrialRunner(base)
        obs = observe_trials(design.trials(), base, folder / "observations", runner=runner, progress=progress)

        def read(params, runner=runner, base=base, obs=obs, name=name):
            cfg = dataclasses.replace(base, model="observer", observer=params)
            return add_report_noise(_columns([runner.readout(o, cfg) for o in obs]), PARTICIPANT, name)

        out[name] = (read, runner)
    return out


def _stats(ref: dict, dark: dict, sep: dict) -> dict[str, float]:
    """``STATS`` of one set of the three designs' tables (``phenomena``'s definitions)."""
    from .phenomena import _curve, _half_crossings, _mean_error_x, _near, _separation_ratio

    times, curve = _curve(ref)
    peak_t, onset, fwhm = _half_crossings(times, curve)
    values = (
        float(curve.max()),
        peak_t,
        onset,
        fwhm,
        _mean_error_x(dark, -50) - _mean_error_x(dark, -150),
        _mean_error_x(dark, 50) - _mean_error_x(dark, -150),
        _near(ref, 0) - _near(ref, 1),
        _separation_ratio(sep),
    )
    return dict(zip(STATS, values))


def _with_ci(tables: list[dict], n_boot: int, seed: int = 0) -> dict[str, tuple[float, float, float]]:
    """Each statistic and its 95 % percentile CI over ``n_boot`` replicates of the experiment (each
    table's reports resampled within their design cells, ``phenomena.resample_cells``); an undefined
    replicate makes the CI undefined (NaN), not narrower, as the scoreboard's."""
    from .phenomena import _cells, resample_cells

    point = _stats(*tables)
    rng = np.random.default_rng(seed)
    cells = [_cells(t) for t in tables]
    reps: dict[str, list] = {k: [] for k in STATS}
    for _ in range(n_boot):
        with np.errstate(all="ignore"):
            for k, v in _stats(*(resample_cells(t, c, rng) for t, c in zip(tables, cells))).items():
                reps[k].append(v)
    out = {}
    for k in STATS:
        r = np.asarray(reps[k], float)
        lo, hi = (np.percentile(r, 2.5), np.percentile(r, 97.5)) if np.all(np.isfinite(r)) else (math.nan, math.nan)
        out[k] = (point[k], float(lo), float(hi))
    return out


def sweep(
    timings_ms,
    folder: Path,
    *,
    image_size: int = 256,
    quick: bool = False,
    progress: bool = False,
    n_boot: int = BOOT,
) -> list[dict]:
    """One row (``COLUMNS``) per timing s.d. of ``timings_ms``: the calibrated prior and the statistics
    at it with their bootstrap CIs (``n_boot`` replicates). ``folder``: where the observations are
    cached (``DIR/observations``, as ``phenomena``)."""
    from .observer import ObserverParams
    from .phenomena import _curve

    readers = _readers(Path(folder), image_size, quick, progress)
    rows = []
    try:
        read_ref = readers["references"][0]
        for tsd in timings_ms:

            def peak_at(prior, tsd=tsd):
                # a time whose flashes all collapse onto the prior has no index (its perceived spread is
                # below the report noise's): left out, as it lies on the far side of the target
                with np.errstate(invalid="ignore"):
                    curve = _curve(read_ref(ObserverParams(prior_sd_deg=prior, temporal_sd_ms=tsd)))[1]
                return float(np.nanmax(curve)) if np.isfinite(curve).any() else math.nan

            prior = round(calibrated_prior(peak_at), 1)
            params = ObserverParams(prior_sd_deg=prior, temporal_sd_ms=float(tsd))
            tables = [readers[d][0](params) for d in DESIGNS]
            row = {"temporal_sd_ms": float(tsd), "prior_sd_deg": prior}
            for k, (v, lo, hi) in _with_ci(tables, n_boot).items():
                row.update({k: v, f"{k}_ci_low": lo, f"{k}_ci_high": hi})
            rows.append(row)
            if progress:
                print(_line(rows[-1]), file=sys.stderr, flush=True)
    finally:
        for _, runner in readers.values():
            runner.close()
    return rows


def _line(r: dict) -> str:
    return " ".join(f"{k}={float(r[k]):.3f}" for k in ("temporal_sd_ms", "prior_sd_deg") + STATS)


def markdown_table(rows: list[dict]) -> str:
    """The docs' table of a sweep's rows (``COLUMNS``, as written to or read from its CSV): each
    statistic with its 95 % CI."""
    head = (
        "| timing s.d. (ms) | prior s.d. (deg) | peak | peak time (ms) | onset (ms) | width (ms) | "
        "dark, −50 ms (deg) | dark, +50 ms (deg) | along − across | separation ratio |"
    )
    fmt = {
        "peak": ".2f",
        "peak_time_ms": ".0f",
        "onset_ms": ".0f",
        "fwhm_ms": ".0f",
        "dark_presaccadic_deg": "+.2f",
        "dark_reversal_deg": "+.2f",
        "along_minus_across": ".2f",
        "separation_ratio": ".2f",
    }
    lines = [head, "|" + "---|" * (2 + len(STATS))]
    for r in rows:
        cells = [f"{float(r['temporal_sd_ms']):g}", f"{float(r['prior_sd_deg']):g}"]
        for k in STATS:
            f = fmt[k]
            cells.append(f"{float(r[k]):{f}} [{float(r[k + '_ci_low']):{f}}, {float(r[k + '_ci_high']):{f}}]")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _positive_ms(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (math.isfinite(v) and 1.0 <= v <= 150.0):
        raise argparse.ArgumentTypeError(f"a timing s.d. must be 1-150 ms (the model's range); got {text}")
    return v


def main(argv: list[str] | None = None) -> int:
    from ..cli.options import add_image_size_option, add_quick_option
    from ..folders import write_csv

    parser = argparse.ArgumentParser(
        prog="python -m experiments.psychophysics.timing_sweep",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--phenomena", type=Path, required=True, help="a `phenomena --out` folder (its observations)")
    parser.add_argument("--timing", type=_positive_ms, nargs="+", default=[21.0, 30.0, 37.0, 40.0, 45.0])
    parser.add_argument("--out", type=Path, default=None, help="write the rows to this CSV")
    parser.add_argument("--bootstrap", type=int, default=BOOT, help=f"replicates of each row's CIs (default {BOOT})")
    add_image_size_option(parser, "pixels per side of each eye, as the phenomena run's (default 256)", default=256)
    add_quick_option(parser, "phenomena --quick's designs (8 flash positions, 2 repetitions)")
    args = parser.parse_args(argv)
    if args.phenomena.exists() and not args.phenomena.is_dir():
        parser.error(f"--phenomena {args.phenomena} is not a folder")
    try:
        if not 20 <= args.bootstrap <= 10_000:
            parser.error(f"--bootstrap must be 20-10000; got {args.bootstrap}")
        rows = sweep(
            args.timing,
            args.phenomena,
            image_size=args.image_size,
            quick=args.quick,
            progress=True,
            n_boot=args.bootstrap,
        )
    except ValueError as exc:
        print(f"timing_sweep: {exc}", file=sys.stderr)
        return 1
    print(markdown_table(rows))
    if args.out is not None:
        write_csv(args.out, list(COLUMNS), [{k: f"{float(r[k]):.6g}" for k in COLUMNS} for r in rows])
    return 0


def read_rows(path: Path = TIMING_CSV) -> list[dict]:
    """A sweep's CSV (``COLUMNS``)."""
    with Path(path).open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    if not rows or tuple(rows[0]) != COLUMNS:
        raise ValueError(f"{path}: columns must be {', '.join(COLUMNS)}")
    return rows


if __name__ == "__main__":
    raise SystemExit(main())
