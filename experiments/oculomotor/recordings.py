"""The table of public real recordings in the docs ("Your eye-tracker's files"): each file read by
``python -m experiments saccades --recording``, its main sequence, the fitted generator, and per
amplitude bin the median peak velocity measured here beside the median of the file's own saccade
events (EyeLink's ``ESACC`` peak velocity, the tracker's own estimate).

    python -m experiments.oculomotor.recordings FILE.asc ... --work DIR   # run, write the two CSVs
    python -m experiments.oculomotor.recordings --docs docs/eyetracker.md  # render the docs' tables
    python -m experiments.oculomotor.recordings --docs docs/eyetracker.md --check

The CSVs live in ``experiments/data/recordings/`` (``recordings.csv``: one row per file; ``bins.csv``:
one row per file and amplitude bin; ``saturated.csv``: the saturated-burst fit of each file's saccades,
``generator_fit.SATURATED_FIT``, through the Python API); the README there names every file, its
source and licence, and which files are bundled. A file without a screen geometry in its header gets one from its ``RES``
line (EyeLink's pixels per degree at the screen's centre) at an assumed 60 cm: near the centre only
the pixels per degree matter.
"""

from __future__ import annotations

import argparse
import csv
import math
import re
import subprocess
import sys
from pathlib import Path
from statistics import median
from typing import Any

__all__ = [
    "BINS_DEG",
    "RECORDING_FIELDS",
    "BIN_FIELDS",
    "SATURATED_FIELDS",
    "saturated_fit",
    "file_events",
    "screen_from_res",
    "run_recording",
    "render",
    "update_docs",
    "main",
]

#: Amplitude bins (deg) of the per-bin medians.
BINS_DEG = ((0.0, 2.0), (2.0, 5.0), (5.0, 10.0), (10.0, 20.0), (20.0, 90.0))
RECORDING_FIELDS = (
    "recording",
    "rate_hz",
    "eye",
    "samples",
    "file_events",
    "saccades",
    "exit",
    "burst_max_deg_s",
    "burst_max_ci",
    "burst_scale_deg",
    "burst_scale_ci",
    "burst_lag_ms",
    "burst_lag_ci",
    "at_bounds",
    "note",
)
BIN_FIELDS = ("recording", "bin_deg", "n_measured", "median_pv_measured", "n_file", "median_pv_file")
SATURATED_FIELDS = (
    "recording",
    "saccades",
    "noise_deg",
    "burst_max_deg_s",
    "burst_max_ci",
    "burst_lag_ms",
    "burst_lag_ci",
    "at_bounds",
    "peak_20_deg_s",
    "result",
)
ASSUMED_DISTANCE_CM = 60.0
_DATA = Path(__file__).resolve().parents[1] / "data" / "recordings"
_FIT_LINE = re.compile(r"^\s+(\w+)\s+(\S+)\s+95% CI \[(\S+), (\S+)\](\s+ON A BOUND)?$")


def file_events(path: str | Path, eye: str) -> list[tuple[float, float]]:
    """(amplitude deg, peak velocity deg/s) of the file's own ``ESACC`` events of ``eye`` (``left`` or
    ``right``), as the tracker wrote them (events with a missing value are left out)."""
    letter = {"left": "L", "right": "R"}[eye]
    out = []
    with open(path, encoding="latin-1") as f:
        for line in f:
            if not line.startswith("ESACC"):
                continue
            parts = line.split()
            if len(parts) < 11 or parts[1] != letter:
                continue
            try:
                amp, pv = float(parts[9]), float(parts[10])
            except ValueError:
                continue
            if math.isfinite(amp) and math.isfinite(pv):
                out.append((amp, pv))
    return out


def screen_from_res(path: str | Path, distance_cm: float = ASSUMED_DISTANCE_CM) -> tuple[float, float, float]:
    """``--screen WIDTH_CM HEIGHT_CM DISTANCE_CM`` from an ASC file's resolution (``GAZE_COORDS`` or
    ``DISPLAY_COORDS``) and its last ``END ... RES x y`` (pixels per degree at the centre):
    ``width_cm = width_px * distance * tan(1 deg) / res_x``."""
    size = res = None
    with open(path, encoding="latin-1") as f:
        for line in f:
            m = re.search(r"(GAZE_COORDS|DISPLAY_COORDS)\s*=?\s*(\S+)\s+(\S+)\s+(\S+)\s+(\S+)", line)
            if m and (size is None or m.group(1) == "GAZE_COORDS"):
                x0, y0, x1, y1 = (float(v) for v in m.groups()[1:])
                size = (x1 - x0 + 1, y1 - y0 + 1)
            m = re.match(r"END\s.*RES\s+(\S+)\s+(\S+)", line)
            if m:
                res = (float(m.group(1)), float(m.group(2)))
    if size is None or res is None:
        raise ValueError(f"{path}: no GAZE_COORDS/DISPLAY_COORDS or no END ... RES line to infer the screen from")
    k = distance_cm * math.tan(math.radians(1.0))
    return round(size[0] * k / res[0], 2), round(size[1] * k / res[1], 2), distance_cm


def run_recording(path: str | Path, out: str | Path, bootstrap: int = 40) -> tuple[dict, list[dict]]:
    """Run ``python -m experiments saccades --recording path`` into ``out``; return the file's row
    (``RECORDING_FIELDS``) and its per-bin rows (``BIN_FIELDS``)."""
    import json

    path, out = Path(path), Path(out)
    try:
        screen = [str(v) for v in screen_from_res(path)]
    except ValueError:  # (a cut-off file: the command says what is wrong with it)
        screen = []
    cmd = [
        sys.executable,
        "-m",
        "experiments",
        "saccades",
        "--recording",
        str(path),
        *(["--screen", *screen] if screen else []),
        "--bootstrap",
        str(bootstrap),
        "--out",
        str(out),
        "--no-progress",
    ]
    done = subprocess.run(cmd, capture_output=True, text=True)
    row: dict[str, Any] = {k: "" for k in RECORDING_FIELDS}
    row.update(recording=path.name, exit=done.returncode)
    ident = out / "recording.json"
    error = [ln for ln in done.stderr.splitlines() if "error:" in ln]
    if done.returncode == 2 or not ident.exists():
        note = error[-1].split("error:", 1)[1].strip() if error else "not read"
        row["note"] = note.replace("argument --recording: ", "").replace(str(path.parent) + "/", "")
        said = re.search(r"in the (left|right) eye", note)  # the eye the command chose
        eye = said.group(1) if said else _recorded_eye(path)
        events = file_events(path, eye)
        row.update(eye=eye, file_events=len(events))
        return row, _bins(path.name, [], events)
    info = json.loads(ident.read_text())
    row.update(
        rate_hz=info["sampling_rate_hz"], eye=info["eye"], samples=info["n_samples"], saccades=info["n_saccades"]
    )
    events = file_events(path, info["eye"])
    row["file_events"] = len(events)
    bounds = []
    for line in done.stdout.splitlines():
        m = _FIT_LINE.match(line)
        if m and m.group(1) in ("burst_max_deg_s", "burst_scale_deg", "burst_lag_ms"):
            key = m.group(1).replace("_deg_s", "").replace("_deg", "").replace("_ms", "")
            row[m.group(1)] = m.group(2)
            row[f"{key}_ci"] = f"[{m.group(3)}, {m.group(4)}]"
            if m.group(5):
                bounds.append(m.group(1))
    row["at_bounds"] = " ".join(bounds)
    why = (
        re.search(
            r"eye\): (?:the generator is not identified by these \d+ saccades \()?(.*?)\)?: no generator", error[-1]
        )
        if error
        else None
    )
    row["note"] = (
        "generator.json written"
        if done.returncode == 0
        else f"not identified: {why.group(1)}"
        if why
        else (error[-1] if error else f"exit {done.returncode}")
    )
    with open(out / "main_sequence.csv", newline="") as f:
        measured = [(float(r["amplitude_deg"]), float(r["peak_velocity_deg_s"])) for r in csv.DictReader(f)]
    return row, _bins(path.name, measured, events)


def saturated_fit(path: str | Path, out: str | Path, bootstrap: int = 40) -> dict | None:
    """The saturated-burst fit (``generator_fit.SATURATED_FIT``, ``burst_scale_deg`` held at
    ``SATURATED_SCALE_DEG``) of the saccades that ``saccades --recording path --out out`` measured
    (``out/main_sequence.csv``), with the recording's tracker noise: a row of ``SATURATED_FIELDS``, or
    None where the command measured no saccades."""
    import json

    import numpy as np

    import models

    from . import eyetracking as et
    from . import generator_fit as gf

    path, out = Path(path), Path(out)
    if not (out / "main_sequence.csv").is_file() or not (out / "recording.json").is_file():
        return None
    info = json.loads((out / "recording.json").read_text())
    with open(out / "main_sequence.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    try:
        w, h, d = screen_from_res(path)
        screen = et.Screen(None, None, w, h, d)
    except ValueError:
        screen = None
    rec = et.read_recording(path, screen=screen, eye=info["eye"])
    row: dict[str, Any] = {k: "" for k in SATURATED_FIELDS}
    row.update(recording=path.name, saccades=len(rows), noise_deg=f"{rec.noise_deg:.4f}")
    try:
        fit = gf.fit_generator(
            rows,
            fit=gf.SATURATED_FIT,
            rate_hz=rec.rate_hz,
            noise_deg=rec.noise_deg,
            bootstrap=bootstrap,
            start=models.BurstGenerator(burst_scale_deg=gf.SATURATED_SCALE_DEG),
        )
    except ValueError as exc:
        row["result"] = f"not fitted: {exc}"
        return row
    for name, key in (("burst_max_deg_s", "burst_max"), ("burst_lag_ms", "burst_lag")):
        lo, hi = fit.ci95[name]
        row[name] = f"{fit.estimates[name]:.3f}"
        row[f"{key}_ci"] = f"[{lo:.4g}, {hi:.4g}]"
    row["at_bounds"] = " ".join(fit.at_bounds)
    peak = gf.predict(fit.generator, np.array([20.0]), rec.rate_hz)["peak_velocity_deg_s"][0]
    row["peak_20_deg_s"] = f"{peak:.0f}" if np.isfinite(peak) else ""
    row["result"] = "identified" if not fit.problems else f"not identified: {'; '.join(fit.problems)}"
    return row


def _recorded_eye(path: Path) -> str:
    """The eye of a file's first ``SAMPLES`` line (``left`` for a binocular file)."""
    with open(path, encoding="latin-1") as f:
        for line in f:
            if line.startswith("SAMPLES"):
                return "right" if "RIGHT" in line.split() and "LEFT" not in line.split() else "left"
    return "left"


def _bins(name: str, measured, events) -> list[dict]:
    rows = []
    for lo, hi in BINS_DEG:
        m = [pv for a, pv in measured if lo <= a < hi]
        e = [pv for a, pv in events if lo <= a < hi]
        if m or e:
            rows.append(
                {
                    "recording": name,
                    "bin_deg": f"{lo:g}-{hi:g}",
                    "n_measured": len(m),
                    "median_pv_measured": f"{median(m):.0f}" if m else "",
                    "n_file": len(e),
                    "median_pv_file": f"{median(e):.0f}" if e else "",
                }
            )
    return rows


# ------------------------------------------------------------------------------------------ docs
_HEADINGS = {
    "recordings.csv": (
        ("recording", "file"),
        ("rate_hz", "Hz"),
        ("eye", "eye"),
        ("samples", "samples"),
        ("file_events", "file's saccades (eye)"),
        ("saccades", "measured"),
        ("burst_max_deg_s", "burst_max (deg/s)"),
        ("burst_max_ci", "95 % CI"),
        ("burst_scale_deg", "burst_scale (deg)"),
        ("burst_scale_ci", "95 % CI"),
        ("burst_lag_ms", "burst_lag (ms)"),
        ("burst_lag_ci", "95 % CI"),
        ("note", "result"),
    ),
    "saturated.csv": (
        ("recording", "file"),
        ("saccades", "saccades"),
        ("noise_deg", "noise (deg)"),
        ("burst_max_deg_s", "burst_max (deg/s)"),
        ("burst_max_ci", "95 % CI"),
        ("burst_lag_ms", "burst_lag (ms)"),
        ("burst_lag_ci", "95 % CI"),
        ("peak_20_deg_s", "peak at 20° (deg/s)"),
        ("result", "result"),
    ),
    "bins.csv": (
        ("recording", "file"),
        ("bin_deg", "amplitude (deg)"),
        ("n_measured", "n measured"),
        ("median_pv_measured", "median peak (deg/s), measured"),
        ("n_file", "n file"),
        ("median_pv_file", "median peak (deg/s), file's events"),
    ),
}
_START = re.compile(r"<!-- recordings table: (?P<name>\S+) -->\n")
_END = "<!-- end of recordings table -->"


def render(csv_path: str | Path) -> str:
    """The markdown table of one of the two CSVs (by its file name)."""
    csv_path = Path(csv_path)
    cols = _HEADINGS.get(csv_path.name)
    if cols is None:
        raise ValueError(f"{csv_path.name} is not one of {', '.join(_HEADINGS)}")
    with open(csv_path, newline="") as f:
        rows = list(csv.DictReader(f))
    lines = ["| " + " | ".join(h for _, h in cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        lines.append("| " + " | ".join((r.get(c) or "–").replace("|", "/") for c, _ in cols) + " |")
    return "\n".join(lines) + "\n"


def update_docs(page: str | Path, check: bool = False, data: Path = _DATA) -> list[str]:
    """Rewrite (or, with ``check``, compare) every marked table of ``page`` from its CSV in ``data``;
    returns the names of the tables that differ."""
    page = Path(page)
    text = page.read_text()
    out, pos, stale = [], 0, []
    for m in _START.finditer(text):
        end = text.index(_END, m.end())
        table = render(data / m.group("name"))
        if text[m.end() : end] != table:
            stale.append(m.group("name"))
        out += [text[pos : m.end()], table]
        pos = end
    out.append(text[pos:])
    if stale and not check:
        from ..folders import atomic_write_text

        atomic_write_text(page, "".join(out))
    return stale


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m experiments.oculomotor.recordings",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("files", nargs="*", type=Path, help="ASC files to run (each into WORK/<name>)")
    parser.add_argument(
        "--work", type=Path, default=Path("results/recordings"), help="output folders (default: %(default)s)"
    )
    parser.add_argument("--data", type=Path, default=_DATA, help="where the two CSVs go (default: %(default)s)")
    parser.add_argument(
        "--bootstrap", type=int, default=40, help="bootstrap resamples of each fit (default: %(default)s)"
    )
    parser.add_argument("--docs", type=Path, help="a docs page whose marked tables are rendered from the CSVs")
    parser.add_argument("--check", action="store_true", help="with --docs: exit 1 where a table is not its CSV's")
    args = parser.parse_args(argv)
    if args.files:
        from ..folders import write_csv

        rows, bins, saturated = [], [], []
        for f in args.files:
            if not f.is_file():
                parser.error(f"{f} is not a file")
            r, b = run_recording(f, args.work / f.stem, args.bootstrap)
            print(f"{f.name}: {r['saccades'] or 0} saccades; {r['note']}")
            rows.append(r)
            bins += b
            s = saturated_fit(f, args.work / f.stem, args.bootstrap) if r["exit"] in (0, 3) else None
            if s is not None:
                print(f"{f.name}: saturated fit: {s['result']}")
                saturated.append(s)
        write_csv(args.data / "recordings.csv", list(RECORDING_FIELDS), rows)
        write_csv(args.data / "bins.csv", list(BIN_FIELDS), bins)
        write_csv(args.data / "saturated.csv", list(SATURATED_FIELDS), saturated)
    if args.docs:
        stale = update_docs(args.docs, check=args.check, data=args.data)
        if stale and args.check:
            print(f"{args.docs}: tables not rendered from {', '.join(stale)}; run without --check", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
