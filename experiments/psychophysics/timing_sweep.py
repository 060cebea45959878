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
participant's report noise as the scoreboard adds it), each statistic with its 95 % CI from ``BOOT``
resamples, as the scoreboard's (``phenomena.statistics`` and ``phenomena.bootstrap`` of these rows). Nothing here sets a constant of the model:
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
#: The scoreboard's rows read out at each timing s.d. (``phenomena.ROWS``, ``phenomena.statistics``).
STATS = (
    "compression_peak",
    "compression_peak_time_ms",
    "compression_onset_ms",
    "compression_fwhm_ms",
    "shift_dark_presaccadic_deg",
    "shift_dark_reversal_deg",
    "compression_along_minus_across",
    "separation_over_localization",
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
    from .phenomena import _curve, bootstrap, statistics

    readers = _readers(Path(folder), image_size, quick, progress)
    rows = []
    try:
        read_ref = readers["references"][0]
        for tsd in timings_ms:

            def peak_at(prior, tsd=tsd):
                # a time whose flashes all collapse onto the prior has no index (its perceived spread is
                # below the report noise's): left out, as it lies on the far side of the target
                curve = _curve(read_ref(ObserverParams(prior_sd_deg=prior, temporal_sd_ms=tsd)))[1]
                return float(np.nanmax(curve)) if np.isfinite(curve).any() else math.nan

            prior = round(calibrated_prior(peak_at), 1)
            params = ObserverParams(prior_sd_deg=prior, temporal_sd_ms=float(tsd))
            tab = {d: readers[d][0](params) for d in DESIGNS}
            row = {"temporal_sd_ms": float(tsd), "prior_sd_deg": prior}
            ci = bootstrap(tab, n_boot, rows=STATS)
            for k, v in statistics(tab, rows=STATS).items():
                row.update({k: v, f"{k}_ci_low": ci[k][0], f"{k}_ci_high": ci[k][1]})
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
    fmt = dict(zip(STATS, (".2f", ".0f", ".0f", ".0f", "+.2f", "+.2f", ".2f", ".2f")))
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
    from ..cli.parsing import int_in
    from ..folders import write_csv

    parser = argparse.ArgumentParser(
        prog="python -m experiments.psychophysics.timing_sweep",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--phenomena", type=Path, required=True, help="a `phenomena --out` folder (its observations)")
    parser.add_argument(
        "--timing", type=_positive_ms, nargs="+", default=[21.0, 30.0, 37.0, 40.0, 45.0, 60.0, 80.0, 100.0]
    )
    parser.add_argument("--out", type=Path, default=None, help="write the rows to this CSV")
    parser.add_argument(
        "--bootstrap",
        type=int_in(20, 10_000),
        default=BOOT,
        help=f"replicates of each row's CIs (20-10000, default {BOOT})",
    )
    add_image_size_option(parser, "pixels per side of each eye, as the phenomena run's (default 256)", default=256)
    add_quick_option(parser, "phenomena --quick's designs (8 flash positions, 2 repetitions)")
    args = parser.parse_args(argv)
    if args.phenomena.exists() and not args.phenomena.is_dir():
        parser.error(f"--phenomena {args.phenomena} is not a folder")
    try:
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
