"""argparse types shared by the commands: bounded numbers and output paths.

Each raises ``argparse.ArgumentTypeError`` with what was wrong, so a bad option ends in a usage
error (exit 2) with one line naming the option, never a traceback, a NaN or a silent truncation.
"""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path
from typing import Callable

__all__ = ["int_in", "float_in", "out_dir", "out_file"]


def int_in(minimum: int, maximum: int) -> Callable[[str], int]:
    """A whole number in [minimum, maximum]: ``12`` or ``12.0``; not ``12.5``, ``nan``, ``inf``,
    ``abc`` or anything outside the range."""

    def parse(text: str) -> int:
        want = f"a whole number in [{minimum}, {maximum}]"
        try:
            v = int(text)
        except ValueError:
            try:
                f = float(text)
            except ValueError:
                raise argparse.ArgumentTypeError(f"expected {want}; got {text!r}") from None
            if not (math.isfinite(f) and f.is_integer()):
                raise argparse.ArgumentTypeError(f"expected {want}; got {text!r}") from None
            v = int(f)
        if not minimum <= v <= maximum:
            raise argparse.ArgumentTypeError(f"expected {want}; got {text!r}")
        return v

    parse.__name__ = "integer"
    return parse


def float_in(minimum: float, maximum: float, *, open_min: bool = False) -> Callable[[str], float]:
    """A finite number in [minimum, maximum] (or (minimum, maximum] with ``open_min``)."""

    def parse(text: str) -> float:
        want = f"a number in {'(' if open_min else '['}{minimum:g}, {maximum:g}]"
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {want}; got {text!r}") from None
        if not math.isfinite(v) or v > maximum or v < minimum or (open_min and v == minimum):
            raise argparse.ArgumentTypeError(f"expected {want}; got {text!r}")
        return v

    parse.__name__ = "number"
    return parse


def _writable_parent(p: Path, text: str) -> None:
    parent = p.parent if str(p.parent) else Path(".")
    anc = parent
    while not anc.exists():  # the nearest existing ancestor must be a writable folder
        anc = anc.parent
    if not anc.is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} lies under {str(anc)!r}, which is a file, not a folder")
    if not os.access(anc, os.W_OK | os.X_OK):
        raise argparse.ArgumentTypeError(f"cannot write under {str(anc)!r} (permission denied); choose another path")


def out_dir(text: str) -> Path:
    """An output folder: not empty, not an existing file, under a folder this user can write."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a folder path; got an empty string")
    p = Path(text)
    if p.exists() and not p.is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} exists and is not a folder; choose a folder path")
    if p.is_dir():
        if not os.access(p, os.W_OK | os.X_OK):
            raise argparse.ArgumentTypeError(f"cannot write into {text!r} (permission denied); choose another folder")
        return p
    _writable_parent(p, text)
    return p


def out_file(suffix: str) -> Callable[[str], Path]:
    """An output file ending in ``suffix``: not a folder, under a folder this user can write."""

    def parse(text: str) -> Path:
        if not text.strip():
            raise argparse.ArgumentTypeError("expected a file path; got an empty string")
        p = Path(text)
        if p.suffix != suffix:
            raise argparse.ArgumentTypeError(f"expected a path ending in {suffix}; got {text!r}")
        if p.is_dir():
            raise argparse.ArgumentTypeError(f"{text!r} is a folder; give a file path ending in {suffix}")
        _writable_parent(p, text)
        return p

    parse.__name__ = "path"
    return parse
