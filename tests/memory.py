"""Resident-memory reading shared by the tests that check for growth over many iterations."""

from __future__ import annotations

import ctypes
import os
from pathlib import Path


def rss_kb() -> int:
    """Resident memory (kB) after returning the C heap's free pages to the OS (glibc's
    malloc_trim, where available), so that allocator fragmentation does not pass for growth."""
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass
    return int(Path("/proc/self/statm").read_text().split()[1]) * os.sysconf("SC_PAGE_SIZE") // 1024
