"""Why a fit of the burst generator ends on a bound: a recording's main sequence per amplitude bin
beside the generator's, measured the same way, and the fit's cost along ``burst_scale_deg``.

* :func:`bin_table`: per amplitude bin, the recorded saccades' median amplitude, peak velocity and
  duration beside the generator's saccade of that median amplitude, simulated, sampled at the
  recording's rate and measured as the recording was (``generator_fit.predict``: Savitzky-Golay
  speed, 30 deg/s crossings, the tracker's noise added).
* :func:`scale_profile`: ``burst_max_deg_s`` and ``burst_lag_ms`` refitted with ``burst_scale_deg``
  held at each value given; the cost is the mean squared log residual of peak velocity and
  duration. A flat cost below some scale means the saccades do not identify the scale there.
* :func:`saturated_burst_peak_deg_s`: the fastest eye a burst of ceiling ``B`` can drive through the
  plant's short time constant ``T2``. A burst at its ceiling from onset to offset (the limit
  ``burst_scale_deg -> 0``: pulse-width modulation, Bahill, Clark & Stark 1975, Math Biosci 24:191)
  lasts ``A / B``; through ``1 / (1 + s T2)`` (Robinson 1964, J Physiol 174:245) the eye's speed
  peaks at its end, ``B (1 - exp(-A / (B T2)))``: a saturating main sequence with ``C = B T2``.

``python -m experiments.oculomotor.fit_diagnosis DIR ...`` prints both tables for the
``main_sequence.csv`` of each folder written by ``saccades --recording`` (docs/eyetracker.md).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import math
import sys
from pathlib import Path

import numpy as np

from . import generator_fit as gf

__all__ = ["BINS_DEG", "bin_table", "scale_profile", "saturated_burst_peak_deg_s", "main"]

#: Amplitude bins (deg) of :func:`bin_table` (those of the docs' recordings table, from 0.5 deg).
BINS_DEG = ((0.5, 2.0), (2.0, 5.0), (5.0, 10.0), (10.0, 20.0), (20.0, 90.0))


def saturated_burst_peak_deg_s(amplitude_deg, burst_max_deg_s: float, t2_ms: float) -> np.ndarray:
    """Peak eye speed (deg/s) of a rectangular burst of height ``burst_max_deg_s`` and area
    ``amplitude_deg`` through a first-order plant of time constant ``t2_ms`` (module docstring)."""
    a = np.asarray(amplitude_deg, float)
    if burst_max_deg_s <= 0 or t2_ms <= 0 or np.any(a < 0):
        raise ValueError("amplitude_deg must be >= 0, burst_max_deg_s and t2_ms > 0")
    return burst_max_deg_s * -np.expm1(-a / (burst_max_deg_s / 1000.0 * t2_ms))


def _arrays(rows) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return gf._rows_arrays(rows)


def bin_table(rows, generator, *, rate_hz: float, noise_deg: float = 0.0, bins=BINS_DEG) -> list[dict]:
    """Per bin of ``bins`` holding saccades of ``rows`` (``main_sequence_rows``): ``n``, the medians
    ``amplitude_deg``, ``pv_data``, ``du_data`` and the ``generator``'s ``pv_model``, ``du_model`` at
    that median amplitude, measured as the data were (module docstring)."""
    A, pv, du = _arrays(rows)
    out = []
    for lo, hi in bins:
        m = (A >= lo) & (A < hi)
        if not m.any():
            continue
        a = float(np.median(A[m]))
        p = gf.predict(generator, np.array([a]), rate_hz, noise_deg)
        out.append(
            dict(
                bin_deg=f"{lo:g}-{hi:g}",
                n=int(m.sum()),
                amplitude_deg=a,
                pv_data=float(np.median(pv[m])),
                du_data=float(np.median(du[m])),
                pv_model=float(p["peak_velocity_deg_s"][0]),
                du_model=float(p["duration_ms"][0]),
            )
        )
    return out


def scale_profile(rows, scales, *, rate_hz: float, noise_deg: float = 0.0, start=None) -> list[dict]:
    """For each ``burst_scale_deg`` in ``scales``: ``burst_max_deg_s`` and ``burst_lag_ms`` fitted with
    the scale held (``generator_fit.fit_generator``, no bootstrap; the rest from ``start``), and the
    fit's cost, the mean of the squared log residuals of peak velocity and duration."""
    import models

    A, pv, du = _arrays(rows)
    base = start or models.BurstGenerator()
    out = []
    for b in scales:
        f = gf.fit_generator(
            rows,
            fit=("burst_max_deg_s", "burst_lag_ms"),
            rate_hz=rate_hz,
            noise_deg=noise_deg,
            bootstrap=0,
            start=dataclasses.replace(base, burst_scale_deg=float(b)),
        )
        p = gf.predict(f.generator, A, rate_hz)
        r = np.concatenate([np.log(pv / p["peak_velocity_deg_s"]), np.log(du / p["duration_ms"])])
        r = r[np.isfinite(r)]
        out.append(dict(burst_scale_deg=float(b), cost=float(np.mean(r**2)), **f.estimates))
    return out


def _read_rows(folder: Path) -> tuple[list[dict], float]:
    import json

    with open(folder / "main_sequence.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    rate = float(json.loads((folder / "recording.json").read_text())["sampling_rate_hz"])
    return rows, rate


def _tracker_noise(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"expected a number of degrees in [0, 1]; got {text!r}")
    return value


def main(argv: list[str] | None = None) -> int:
    import models

    parser = argparse.ArgumentParser(
        prog="python -m experiments.oculomotor.fit_diagnosis",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("folders", nargs="+", type=Path, help="folders written by `saccades --recording`")
    parser.add_argument(
        "--tracker-noise-deg",
        type=_tracker_noise,
        default=0.0,
        metavar="DEG",
        help="the recording's tracker noise per axis, as `saccades --recording` prints it (deg, 0-1; default 0)",
    )
    parser.add_argument(
        "--scales", default="0.01,0.1,0.3,0.6,1,2,2.82", help="burst_scale_deg values of the profile (comma-separated)"
    )
    args = parser.parse_args(argv)
    try:
        scales = [float(s) for s in args.scales.split(",")]
    except ValueError:
        parser.error(f"--scales must be comma-separated numbers; got {args.scales!r}")
    for folder in args.folders:
        try:
            rows, rate = _read_rows(folder)
        except (OSError, KeyError, ValueError) as exc:
            parser.error(f"{folder}: not a folder written by `saccades --recording` ({exc})")
        print(f"{folder.name} ({rate:g} Hz, {len(rows)} saccades): data vs the default generator")
        for r in bin_table(rows, models.BurstGenerator(), rate_hz=rate, noise_deg=args.tracker_noise_deg):
            print(
                f"  {r['bin_deg']:>6} deg  n={r['n']:3d}  A={r['amplitude_deg']:5.1f}  peak {r['pv_data']:4.0f} vs "
                f"{r['pv_model']:4.0f} deg/s  duration {r['du_data']:5.1f} vs {r['du_model']:5.1f} ms"
            )
        print("  burst_scale_deg held, burst_max_deg_s and burst_lag_ms refitted:")
        for r in scale_profile(rows, scales, rate_hz=rate, noise_deg=args.tracker_noise_deg):
            print(
                f"  scale {r['burst_scale_deg']:5.2f} deg  cost {r['cost']:.4f}  burst_max {r['burst_max_deg_s']:6.1f} "
                f"deg/s  burst_lag {r['burst_lag_ms']:5.2f} ms"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
