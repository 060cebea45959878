"""EyeLink ASC files (``edf2asc`` output) as arrays: samples of each recorded eye, blocks, events.

Why not ``pymovements.gaze.from_asc`` (0.28, read before writing this): its parser reads one layout
per file and, on the files labs have, (1) finds no sampling rate in remote mode -- its ``SAMPLES``
regex expects ``RATE`` right after the eyes, and ``SAMPLES GAZE LEFT HTARGET RATE 500.00`` ends in
``float(None)``; (2) takes the resolution from ``GAZE_COORDS`` only, and only after a ``RECCFG``
line, so EyeLink I/II files (``DISPLAY_COORDS``) have none; (3) returns every eye's events, so a
binocular file gives each saccade twice; (4) keeps the whole-millisecond time stamps that
``edf2asc`` writes twice at 2000 Hz (without ``-ftime``); (5) loses the START/END blocks, so the gap
between two trials looks like a slow movement. What is kept from it: its regular expressions'
reading of the lines (``SSACC``/``ESACC``/``SBLINK``/``EBLINK``, ``.`` for a lost sample) and its
rule that ``GAZE_COORDS`` gives the highest pixel index (resolution = right - left + 1).

The layout of a sample line (SR Research, *EyeLink 1000 Plus User Manual*, "Sample line format" of
the ASC-file chapter): ``time  xl yl pl  [xr yr pr]  [velocities] [resolution] [input] flags
[remote: target x, target y, target distance, target flags]``. Only the first 1 + 3 x (number of
eyes) fields are read; the rest is ignored, so ``-vel``, ``-res``, ``-input`` and remote mode
(``HTARGET``) need nothing more.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import TypedDict

import numpy as np

__all__ = ["AscData", "AscError", "parse_asc", "EYES"]

EYES = ("left", "right")
_NUM = re.compile(r"[-+]?\d+(?:\.\d*)?")


class AscError(ValueError):
    """An ASC file that cannot be read; the message names the line and the problem."""


@dataclass
class AscData:
    """What an ASC file holds, per sample: ``times_ms`` (whole-ms stamps written twice at 2000 Hz are
    spread to their true times), ``block`` (index of the START/END block), ``x_px``/``y_px``:
    ``{eye: array}`` for each eye any block recorded (NaN where lost or not recorded), the rate,
    the resolution and where it came from, and the events ``(kind, eye, start_ms, end_ms)`` with
    kind ``saccade`` or ``blink``."""

    times_ms: np.ndarray
    block: np.ndarray
    x_px: dict
    y_px: dict
    rate_hz: float
    resolution: tuple[int, int] | None
    resolution_source: str | None
    events: list = field(default_factory=list)
    remote: bool = False
    n_blocks: int = 0

    @property
    def eyes(self) -> tuple[str, ...]:
        return tuple(e for e in EYES if e in self.x_px)


def _coords(line: str, n_line: int) -> tuple[int, int]:
    nums = [float(v) for v in _NUM.findall(line.split("COORDS", 1)[1])]
    if len(nums) != 4 or nums[2] <= nums[0] or nums[3] <= nums[1]:
        raise AscError(f"line {n_line}: {line.strip()[:80]!r} needs four numbers: left top right bottom")
    return int(round(nums[2] - nums[0] + 1)), int(round(nums[3] - nums[1] + 1))  # highest index, 0-based


def _eyes_of(tokens: list[str]) -> tuple[str, ...]:
    eyes = []
    for tok in tokens:
        t = tok.upper()
        if t in ("LEFT", "L") and "left" not in eyes:
            eyes.append("left")
        elif t in ("RIGHT", "R") and "right" not in eyes:
            eyes.append("right")
        elif t == "LR":
            eyes = ["left", "right"]
    return tuple(e for e in EYES if e in eyes)


def _spread_times(t: np.ndarray, rate_hz: float, n_line: int) -> np.ndarray:
    """Whole-ms stamps above 1000 Hz (``edf2asc`` without ``-ftime``: 1000, 1000, 1001, 1001 at
    2000 Hz) spread to ``stamp + k / rate`` for the k-th repeat of a stamp."""
    if len(t) < 2:
        return t
    period = 1000.0 / rate_hz
    same = np.concatenate([[False], t[1:] == t[:-1]])
    if not same.any():
        return t
    per_ms = int(math.ceil(1.0 / period - 1e-9))
    if rate_hz <= 1000.0 or not np.all(t == np.round(t)):
        i = int(np.argmax(same))
        raise AscError(
            f"sample time {t[i]:g} ms repeats (block starting at line {n_line}) at {rate_hz:g} Hz: "
            "corrupt or concatenated file"
        )
    # k-th repeat of a stamp: index minus the index where its run started
    idx = np.arange(len(t))
    start = np.maximum.accumulate(np.where(~same, idx, 0))
    rep = idx - start
    if rep.max() >= per_ms:
        raise AscError(
            f"sample time {t[int(np.argmax(rep >= per_ms))]:g} ms is written {int(rep.max()) + 1} times "
            f"(at most {per_ms} at {rate_hz:g} Hz): corrupt or concatenated file"
        )
    return t + rep * period


def _value(v: str) -> float:
    return math.nan if v == "." else float(v)


def _sample_values(lines: list[str], rows: list[int], need: int, eyes, name: str, block_line: int) -> np.ndarray:
    """The first ``need`` fields of the sample lines ``rows`` as floats (NaN for ``.``), (n, need)."""
    try:
        flat = np.fromiter((_value(v) for i in rows for v in lines[i].split(None, need)[:need]), float)
        if flat.size == len(rows) * need:
            return flat.reshape(len(rows), need)
    except ValueError:
        pass
    for i in rows:  # locate the first bad line (only on the error path)
        f = lines[i].split(None, need)[:need]
        if len(f) < need:
            raise AscError(
                f"line {i + 1}: a sample with {len(lines[i].split())} fields where {'/'.join(eyes)} samples "
                f"have at least {need} (time, then x, y, pupil per eye): corrupt file, or a SAMPLES line "
                "naming the wrong eyes"
            )
        for v in f:
            try:
                _value(v)
            except ValueError:
                raise AscError(
                    f"line {i + 1}: a sample holds {v[:20]!r}, not a number or '.' (block starting on line "
                    f"{block_line})"
                ) from None
    raise AscError(f"{name}: cannot read the samples of the block starting on line {block_line}")  # pragma: no cover


class _Block(TypedDict):
    """A START/END block while it is read: its first line, eyes, rate, remote flag, sample line indices."""

    line: int
    eyes: tuple[str, ...]
    rate: float | None
    remote: bool
    rows: list[int]


def parse_asc(text: str, name: str = "the file") -> AscData:
    """Parse the text of an ASC file (see the module docstring). :class:`AscError` for what cannot
    be read: no sampling rate, a sample line with too few fields, time going backwards, a block
    without END."""
    lines = text.splitlines()
    blocks: list[_Block] = []  # the blocks read, in order
    gaze_res = display_res = None
    events: list = []
    cur: _Block | None = None
    rate_reccfg = None
    for n, ln in enumerate(lines, 1):
        c = ln[:1]
        if c.isdigit():
            if cur is None:
                continue  # samples outside START/END: edf2asc never writes them; ignore
            cur["rows"].append(n - 1)  # the line's index: parsed per block, once its layout is known
            continue
        if not c.isalpha():
            continue
        head = ln.split(None, 1)[0] if ln.strip() else ""
        if head == "START":
            if cur is not None:
                raise AscError(
                    f"line {n}: START inside the block that starts on line {cur['line']} (no END "
                    "before it): corrupt or concatenated file"
                )
            cur = {"line": n, "eyes": _eyes_of(ln.split()[2:]), "rate": None, "remote": False, "rows": []}
        elif head == "SAMPLES":
            tok = ln.split()
            if cur is None:
                continue
            eyes = _eyes_of(tok[1:])
            if eyes:
                cur["eyes"] = eyes
            cur["remote"] = "HTARGET" in (t.upper() for t in tok)
            if "RATE" in tok:
                k = tok.index("RATE")
                try:
                    cur["rate"] = float(tok[k + 1])
                except (IndexError, ValueError):
                    raise AscError(f"line {n}: SAMPLES line {ln.strip()[:80]!r} has no number after RATE") from None
        elif head == "END":
            if cur is None:
                raise AscError(f"line {n}: END without a START: corrupt file")
            blocks.append(cur)
            cur = None
        elif head == "MSG":
            if "GAZE_COORDS" in ln:
                r = _coords(ln, n)
                if gaze_res is not None and r != gaze_res:
                    raise AscError(
                        f"line {n}: GAZE_COORDS {r[0]} x {r[1]} differs from the earlier {gaze_res[0]} x "
                        f"{gaze_res[1]}; split the file where the display changed"
                    )
                gaze_res = r
            elif "DISPLAY_COORDS" in ln:
                display_res = _coords(ln, n)
            elif " RECCFG " in ln:
                tok = ln.split()
                k = tok.index("RECCFG")
                if len(tok) > k + 2 and tok[k + 2].isdigit():
                    rate_reccfg = float(tok[k + 2])
        elif head in ("ESACC", "EBLINK"):
            tok = ln.split()
            try:
                eye = {"L": "left", "R": "right"}[tok[1].upper()]
                t0, t1 = float(tok[2]), float(tok[3])
            except (IndexError, KeyError, ValueError):
                raise AscError(
                    f"line {n}: cannot read the event {ln.strip()[:80]!r} (expected '{head} L|R START END ...')"
                ) from None
            events.append(("saccade" if head == "ESACC" else "blink", eye, t0, t1))
    if cur is not None:
        raise AscError(
            f"{name} looks truncated: the recording block that starts on line {cur['line']} has no END "
            "line (was the file cut short while copying or converting?)"
        )
    if not blocks:
        raise AscError(f"{name}: no START/END block: not a recording of an EyeLink ASC file")
    times: list[np.ndarray] = []
    block_ix: list[np.ndarray] = []
    xs: dict[str, list[np.ndarray]] = {e: [] for e in EYES}
    ys: dict[str, list[np.ndarray]] = {e: [] for e in EYES}
    rates: set[float] = set()
    remote = False
    for b, blk in enumerate(blocks):
        if not blk["rows"]:
            continue
        eyes = blk["eyes"] or ("left",)
        rate = blk["rate"] or rate_reccfg
        if not rate:
            raise AscError(
                f"{name}: the block starting on line {blk['line']} has no sampling rate (no 'RATE' on its "
                "SAMPLES line and no RECCFG message)"
            )
        rates.add(rate)
        remote |= blk["remote"]
        need = 1 + 3 * len(eyes)
        vals = _sample_values(lines, blk["rows"], need, eyes, name, blk["line"])
        t = _spread_times(vals[:, 0], rate, blk["line"])
        times.append(t)
        block_ix.append(np.full(len(t), b))
        for e in EYES:
            if e in eyes:
                k = eyes.index(e)
                xs[e].append(vals[:, 1 + 3 * k])
                ys[e].append(vals[:, 2 + 3 * k])
            else:
                xs[e].append(np.full(len(t), np.nan))
                ys[e].append(np.full(len(t), np.nan))
    if not times:
        raise AscError(f"{name}: no samples (was it converted with edf2asc -e, events only?)")
    if len(rates) > 1:
        raise AscError(
            f"{name}: its blocks were sampled at different rates ({', '.join(f'{r:g}' for r in sorted(rates))} Hz); "
            "split the file by rate"
        )
    t = np.concatenate(times)
    d = np.diff(t)
    if np.any(d <= 0):
        i = int(np.argmax(d <= 0)) + 1
        raise AscError(f"{name}: sample times go backwards or repeat (at {t[i]:g} ms): corrupt or concatenated file")
    recorded = {e for blk in blocks for e in (blk["eyes"] or ("left",)) if blk["rows"]}
    res, src = (
        (gaze_res, "GAZE_COORDS") if gaze_res else ((display_res, "DISPLAY_COORDS") if display_res else (None, None))
    )
    return AscData(
        t,
        np.concatenate(block_ix),
        {e: np.concatenate(xs[e]) for e in EYES if e in recorded},
        {e: np.concatenate(ys[e]) for e in EYES if e in recorded},
        float(rates.pop()),
        res,
        src,
        events,
        remote,
        len(blocks),
    )
