"""Whether a native viewer window can open (a display), and the error that says so."""

from __future__ import annotations

import os
import sys


def display_available() -> bool:
    """Whether a native viewer window can open: on Linux (and the BSDs) ``DISPLAY`` or
    ``WAYLAND_DISPLAY`` must be set; elsewhere assumed."""
    if sys.platform.startswith(("linux", "freebsd", "openbsd", "netbsd")):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True


def _no_display_message(flag: str) -> str:
    return (
        f"{flag} needs a display (DISPLAY and WAYLAND_DISPLAY are unset); use --serve to view the run in a "
        "web browser, or --out FILE.rrd to write it"
    )
