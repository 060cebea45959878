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

__all__ = ["int_in", "out_dir", "whole_number"]


def whole_number(text: str) -> int:
    """``text`` as a whole number: ``12``, ``12.0`` or ``1e3``; ``ValueError`` for ``12.5``, ``nan``,
    ``inf`` or anything that is not a number."""
    try:
        return int(text)
    except ValueError:
        f = float(text)  # raises ValueError for non-numbers
        if not (math.isfinite(f) and f.is_integer()):
            raise ValueError(f"not a whole number: {text!r}") from None
        return int(f)


def int_in(minimum: int, maximum: int) -> Callable[[str], int]:
    """A whole number (:func:`whole_number`) in [minimum, maximum]."""

    def parse(text: str) -> int:
        want = f"a whole number in [{minimum}, {maximum}]"
        try:
            v = whole_number(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {want}; got {text!r}") from None
        if not minimum <= v <= maximum:
            raise argparse.ArgumentTypeError(f"expected {want}; got {text!r}")
        return v

    parse.__name__ = "integer"
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
