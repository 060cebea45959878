"""Process helpers shared by the tests that kill commands and look for their workers (Linux /proc)."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Iterator


def children(pid: int) -> list[int]:
    """Direct children of ``pid`` (a /proc scan)."""
    kids = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            if int(stat.rpartition(")")[2].split()[1]) == pid:
                kids.append(int(d.name))
    return kids


def cmdline(pid: int) -> str:
    """The command line of ``pid`` ('' when it is gone)."""
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


def alive(pid: int) -> bool:
    """``pid`` exists and is not a zombie."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()[0]
    except OSError:
        return False
    return state != "Z"


def gone(pids: list[int], timeout: float = 30.0) -> list[int]:
    """The ``pids`` still alive after waiting up to ``timeout`` s for them to exit (a loaded machine's
    margin: workers killed by the kernel go at once)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and any(alive(p) for p in pids):
        time.sleep(0.05)
    return [p for p in pids if alive(p)]


@contextlib.contextmanager
def holding(lock_call: str, path: Path, env: dict) -> Iterator[subprocess.Popen]:
    """Another process holding a lock on ``path`` while the block runs: ``lock_call`` is the
    context manager to hold, as code (e.g. ``"experiments.folders.path_lock"``)."""
    module, _, name = lock_call.rpartition(".")
    holder = subprocess.Popen(
        [sys.executable, "-c", f"import sys\nfrom {module} import {name}\n"
         f"with {name}(sys.argv[1]):\n    print('held', flush=True)\n    sys.stdin.read()", str(path)],
        env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        yield holder
    finally:
        holder.stdin.close()
        holder.wait()


def reap(proc: subprocess.Popen, pids: list[int]) -> None:
    """Clean-up after a test that killed a command: the command and any of ``pids`` still alive."""
    if proc.poll() is None:
        proc.kill()
    for p in pids:
        if alive(p):
            os.kill(p, signal.SIGKILL)
