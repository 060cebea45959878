"""How long a recording takes to open in Rerun's web viewer, measured in headless Chromium, and a
screenshot of each layout once it has.

    python benchmarks/viewer.py results/study.rrd --timeline flash_time --screenshot study.png
    python benchmarks/viewer.py run.rrd --timeline sim_time --screenshot run.png

Serves the file with :class:`experiments.recording.WebViewer` (``rerun --serve-web`` on 127.0.0.1),
opens the viewer's page in Chromium (Playwright, ``--headless``, software rendering, 1600 x 1000),
and polls the viewer's own state (``WebHandle.viewer_state()``, the Viewer Control API's
``GetStateResponse``) every 0.25 s until the time cursor of ``--timeline`` stands at that timeline's
last time point *as written in the file* (read beforehand with Rerun's ``RrdReader``). Prints one table
row: the file's size, the time until the viewer started (wasm loaded), until the recording appeared,
and until the cursor reached the end; then saves the screenshot. The baseline in the same process is
the time the same page takes to reach the end of an empty recording (one scalar), so the ratio is the
recording's own cost.

Needs Chromium (Debian: ``apt-get install chromium``) and Playwright's Python package
(``pip install playwright``; it drives the installed Chromium, nothing is downloaded). Not part of
the test suite: it measures, it does not assert.
"""

from __future__ import annotations

import argparse
import os
import shutil
import socket
import sys
import tempfile
import time
import urllib.parse
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


# ------------------------------------------------------------------ protobuf wire format (just enough)
def _varint(b: bytes, i: int) -> tuple[int, int]:
    r = s = 0
    while True:
        c = b[i]
        i += 1
        r |= (c & 0x7F) << s
        s += 7
        if c < 0x80:
            return r, i


def _fields(b: bytes) -> list[tuple[int, int | bytes]]:
    """Top-level (field number, value) pairs of a protobuf message (varints as ints, the rest bytes)."""
    out: list[tuple[int, int | bytes]] = []
    i = 0
    while i < len(b):
        key, i = _varint(b, i)
        f, wt = key >> 3, key & 7
        v: int | bytes
        if wt == 0:
            v, i = _varint(b, i)
        elif wt == 1:
            v, i = b[i : i + 8], i + 8
        elif wt == 5:
            v, i = b[i : i + 4], i + 4
        elif wt == 2:
            n, i = _varint(b, i)
            v, i = b[i : i + n], i + n
        else:
            raise ValueError(f"unsupported wire type {wt}")
        out.append((f, v))
    return out


def _get(b: bytes, *path: int):
    """The first value at a path of field numbers, or None (also where the path runs through a varint)."""
    val: int | bytes = b
    for f in path:
        if not isinstance(val, bytes):
            return None
        vals = [v for n, v in _fields(val) if n == f]
        if not vals:
            return None
        val = vals[0]
    return val


def cursor(state: bytes, timeline: str) -> tuple[int, int] | None:
    """(current time, last time) of ``timeline`` in the active recording of a ``GetStateResponse``
    (ints: ns for durations, the number for sequences), or None while it has no such timeline.
    Layout read off Rerun 0.41: field 3 = the active recording; in it, field 2 = one entry per
    timeline {1: {1: name}, 3: {1: first, 2: last}, 4: {1: current}}."""
    rec = _get(state, 3)
    if rec is None:
        return None
    for f, entry in _fields(rec):
        if f != 2 or not isinstance(entry, bytes):
            continue
        if _get(entry, 1, 1) == timeline.encode():
            last, cur = _get(entry, 3, 2), _get(entry, 4, 1)  # proto3 leaves out zeros
            return _signed(cur if isinstance(cur, int) else 0), _signed(last if isinstance(last, int) else 0)
    return None


def _signed(v: int) -> int:
    return v - (1 << 64) if v >= 1 << 63 else v


def last_time(path: Path, timeline: str) -> int:
    """The largest time of ``timeline`` in the file (ns for durations), from Rerun's own reader."""
    import pyarrow as pa
    from rerun.chunk import RrdReader

    last = None
    for chunk in RrdReader(str(path)).store().stream().to_chunks():
        b = chunk.to_record_batch()
        if timeline in b.schema.names:
            col = b.column(timeline).cast(pa.int64()).to_numpy()
            if len(col):
                last = int(col.max()) if last is None else max(last, int(col.max()))
    if last is None:
        raise SystemExit(f"{path} has no data on timeline {timeline!r}")
    return last


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def open_in_chromium(
    path: Path, timeline: str, *, timeout_s: float, screenshot: Path | None, size: tuple[int, int] = (1600, 1000)
) -> dict:
    """Serve ``path``, open it headless and time it (see the module docstring)."""
    from playwright.sync_api import sync_playwright

    from experiments.recording import WebViewer

    end = last_time(path, timeline)
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        raise SystemExit("Chromium not found: apt-get install chromium")
    out = {"file": str(path), "MB": os.path.getsize(path) / 1e6, "timeline": timeline}
    with WebViewer(_free_port(), _free_port(), recordings=(str(path),)) as viewer, sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=CHROMIUM_ARGS, headless=True)
        try:
            page = browser.new_page(viewport={"width": size[0], "height": size[1]})
            url = f"http://127.0.0.1:{viewer.web_port}/?url=" + urllib.parse.quote(viewer.grpc_url, safe="")
            t0 = time.monotonic()
            page.goto(url)
            started = appeared = None
            while time.monotonic() - t0 < timeout_s:
                state = page.evaluate("() => window._handle ? Array.from(window._handle.viewer_state()) : null")
                now = time.monotonic() - t0
                if state is not None:
                    started = started or now
                    c = cursor(bytes(state), timeline)
                    if c is not None:
                        appeared = appeared or now
                        if c[0] >= end and c[1] >= end:
                            out.update(started_s=started, appeared_s=appeared, end_s=now)
                            break
                time.sleep(0.25)
            else:
                out.update(started_s=started, appeared_s=appeared, end_s=float("nan"))
            if screenshot is not None:  # once two shots 3 s apart are the same (textures uploaded), <= 90 s
                prev, t1 = None, time.monotonic()
                while True:
                    shot = page.screenshot(timeout=180_000)
                    if shot == prev or time.monotonic() - t1 > 90:
                        break
                    prev = shot
                    time.sleep(3.0)
                screenshot.write_bytes(shot)
                out["settled_s"] = time.monotonic() - t0
        finally:
            browser.close()
    return out


def _empty_recording(folder: Path) -> Path:
    import rerun as rr

    path = folder / "empty.rrd"
    rec = rr.RecordingStream("empty")
    rec.save(str(path))
    rec.set_time("sim_time", duration=0.001)
    rec.log("x", rr.Scalars(0.0))
    rec.flush()
    rec.disconnect()
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("recording", type=Path, help="an .rrd file")
    ap.add_argument("--timeline", default="sim_time", help="the timeline whose end to wait for (default sim_time)")
    ap.add_argument("--timeout", type=float, default=300.0, help="give up after this many seconds (default 300)")
    ap.add_argument("--screenshot", type=Path, default=None, help="save a PNG of the viewer at the end")
    ap.add_argument("--no-baseline", action="store_true", help="skip the empty-recording baseline")
    args = ap.parse_args(argv)
    if not args.recording.is_file():
        ap.error(f"{args.recording} does not exist")
    rows = []
    if not args.no_baseline:
        with tempfile.TemporaryDirectory() as d:
            rows.append(
                (
                    "empty recording (baseline)",
                    open_in_chromium(_empty_recording(Path(d)), "sim_time", timeout_s=args.timeout, screenshot=None),
                )
            )
    rows.append(
        (
            str(args.recording),
            open_in_chromium(args.recording, args.timeline, timeout_s=args.timeout, screenshot=args.screenshot),
        )
    )
    base = rows[0][1]["end_s"] if not args.no_baseline else float("nan")
    print(
        f"{'recording':<40} {'MB':>6} {'viewer up (s)':>14} {'data shown (s)':>15} {'at its end (s)':>15} "
        f"{'/ baseline':>10}"
    )
    for name, r in rows:
        print(
            f"{name[-40:]:<40} {r['MB']:6.2f} {r['started_s'] or float('nan'):14.1f} "
            f"{r['appeared_s'] or float('nan'):15.1f} {r['end_s']:15.1f} {r['end_s'] / base:10.2f}"
            + (f"   (screenshot settled at {r['settled_s']:.0f} s)" if "settled_s" in r else "")
        )
    if args.screenshot is not None:
        print(f"screenshot: {args.screenshot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
