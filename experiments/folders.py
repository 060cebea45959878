"""What every command that writes results relies on: locks, atomic writes, strict JSON, workers
that die with their parent.

* :func:`path_lock` holds an exclusive ``fcntl.flock`` on a lock file for one writer at a time and
  removes the file when released, so a finished command leaves no ``.lock`` behind. A process
  that opened the file just before it was removed would lock a file nobody else can see; it
  checks, after locking, that the path still names the file it locked, and retries if not.
* :func:`atomic_write_text` / :func:`atomic_write_bytes` write to a uniquely named temporary file
  in the target's folder (two processes never share one), ``fsync`` it and rename it over the
  target: a reader sees the old file or the new one, never a torn one.
* :func:`write_json` writes strict JSON (``NaN`` and ``inf`` refused: no bare ``NaN`` that other
  JSON readers reject); :func:`json_safe` turns non-finite floats into ``null`` first where a
  value may legitimately be undefined (an interval that does not exist).
* :func:`die_with_parent`: a worker process exits when its parent dies, even by ``kill -9``
  (Linux ``PR_SET_PDEATHSIG``, and a thread that watches the parent's pid elsewhere).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import signal
import sys
import tempfile
import threading
import time
import types
from collections.abc import Iterator
from pathlib import Path
from typing import Any

__all__ = [
    "Interrupted",
    "interruptible",
    "swallowing_context",
    "LockBusyError",
    "path_lock",
    "atomic_write_text",
    "atomic_write_bytes",
    "save_figure",
    "write_json",
    "write_csv",
    "json_safe",
    "die_with_parent",
    "die_with",
    "check_path_length",
    "os_error_text",
]


class LockBusyError(RuntimeError):
    """Another process holds the lock."""


def check_path_length(path: os.PathLike | str) -> None:
    """``ValueError`` when a component of ``path`` or the whole path is longer than the file system
    allows (``NAME_MAX``, ``PATH_MAX``): say so before any work, not after it."""
    p = Path(path)
    anc = p.absolute()
    while anc != anc.parent:
        try:
            if anc.exists():
                break
        except OSError:  # e.g. ENAMETOOLONG: its parent decides
            pass
        anc = anc.parent
    try:
        name_max = os.pathconf(anc if anc.is_dir() else anc.parent, "PC_NAME_MAX")
        path_max = os.pathconf(anc if anc.is_dir() else anc.parent, "PC_PATH_MAX")
    except (OSError, ValueError, AttributeError):  # pragma: no cover - not POSIX
        name_max, path_max = 255, 4096
    for part in p.parts:
        if len(os.fsencode(part)) > name_max:
            raise ValueError(
                f"the name {part[:40]!r}... is {len(os.fsencode(part))} bytes long; this file system "
                f"allows {name_max}: choose a shorter name"
            )
    if len(os.fsencode(str(p.absolute()))) >= path_max:
        raise ValueError(
            f"the path is {len(os.fsencode(str(p.absolute())))} bytes long; this file system allows "
            f"{path_max - 1}: choose a shorter path"
        )


def _unique_tmp(target: Path) -> tuple[int, str]:
    return tempfile.mkstemp(prefix=f".{target.name[:80]}.", suffix=".tmp", dir=target.parent)


def atomic_write_bytes(path: os.PathLike | str, data: bytes) -> None:
    """Write ``data`` to ``path`` through a unique temporary file in the same folder, then rename."""
    target = Path(path)
    fd, tmp = _unique_tmp(target)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def atomic_write_text(path: os.PathLike | str, text: str) -> None:
    """``atomic_write_bytes`` of UTF-8 text."""
    atomic_write_bytes(path, text.encode("utf-8"))


def save_figure(fig, path: os.PathLike | str, dpi: int = 110, close: bool = True, **savefig: Any) -> Path:
    """A matplotlib figure written atomically (rendered in memory in the format of ``path``'s suffix,
    then :func:`atomic_write_bytes`: an interrupted run leaves the old figure or none, never a torn
    one); closed afterwards unless ``close=False``. Returns the path."""
    import io

    path = Path(path)
    buf = io.BytesIO()
    fig.savefig(buf, dpi=dpi, format=path.suffix.lstrip(".").lower() or "png", **savefig)
    atomic_write_bytes(path, buf.getvalue())
    if close:
        import matplotlib.pyplot as plt

        plt.close(fig)
    return path


def write_csv(path: os.PathLike | str, fieldnames: list[str], rows: list[dict], lineterminator: str = "\n") -> None:
    """A CSV table (a header, then ``rows`` as dicts), written atomically; ``lineterminator``: "\\r\\n"
    for the csv module's default (Excel's)."""
    import csv
    import io

    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=fieldnames, lineterminator=lineterminator)
    w.writeheader()
    w.writerows(rows)
    atomic_write_text(path, buf.getvalue())


def append_csv_row(path: os.PathLike | str, fieldnames, row: dict) -> None:
    """Append one row to a CSV log (its header first when the file is new): a log written as it goes,
    so that an interrupted run keeps the rows it finished."""
    import csv

    path = Path(path)
    new = not path.exists()
    with path.open("a", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(fieldnames))
        if new:
            w.writeheader()
        w.writerow(row)


def os_error_text(e: OSError) -> str:
    """One line for a command's error message: what failed, and on which file."""
    name = getattr(e, "filename", None)
    return f"{e.strerror or e}{f': {name}' if name else ''}"


def json_safe(obj: Any) -> Any:
    """``obj`` with every non-finite float replaced by ``None`` (JSON ``null``), numpy scalars and
    arrays as Python numbers and lists."""
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if hasattr(obj, "tolist") and not isinstance(obj, (str, bytes)):
        return json_safe(obj.tolist())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def write_json(path: os.PathLike | str, obj: Any) -> None:
    """Strict JSON (``allow_nan=False``: a NaN that reached here is a bug, not an output), written
    atomically. Pass values that may be undefined through :func:`json_safe` first."""
    atomic_write_text(path, json.dumps(obj, indent=2, allow_nan=False) + "\n")


@contextlib.contextmanager
def path_lock(lock_path: os.PathLike | str, what: str = "the folder") -> Iterator[None]:
    """Hold an exclusive lock on ``lock_path`` (created, and removed on release) while the block
    runs; :class:`LockBusyError` at once (no waiting) when another process holds it."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX: no locking
        yield
        return
    path = Path(lock_path)
    for _ in range(100):
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            try:
                owner = os.pread(fd, 64, 0).decode(errors="replace").strip()
            except OSError:
                owner = ""
            os.close(fd)
            raise LockBusyError(
                f"{what} is in use by another run{f' (pid {owner})' if owner.isdigit() else ''}"
                ": wait for it to finish, or use another --out"
            ) from None
        try:
            same = os.fstat(fd).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)  # the holder removed it between our open and our lock: lock the new one
    else:  # pragma: no cover - a hundred races in a row
        raise LockBusyError(f"{what}: could not take its lock {path}")
    try:
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        yield
    finally:
        with contextlib.suppress(OSError):
            os.unlink(path)  # while still holding it: a waiter that opened it re-checks the inode
        with contextlib.suppress(OSError):
            fcntl.flock(fd, fcntl.LOCK_UN)
        os.close(fd)


def die_with(pid: int, period_s: float = 0.5) -> None:
    """Exit this process (``os._exit``) once process ``pid`` on this machine is gone, checked every
    ``period_s`` by a daemon thread: for workers whose parent is not the process they serve (Ray's
    actors are children of its raylet, not of the driver)."""

    def alive() -> bool:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        except PermissionError:  # pragma: no cover - exists, owned by another user
            return True
        try:  # a zombie (killed, not yet reaped) is gone too
            return Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()[0] != "Z"
        except OSError:
            return True  # no /proc: kill(pid, 0) said it exists

    def watch() -> None:
        while alive():
            time.sleep(period_s)
        os._exit(1)

    threading.Thread(target=watch, name="driver-watchdog", daemon=True).start()


def die_with_parent(parent_pid: int) -> None:
    """Make this (worker) process exit when ``parent_pid`` dies, even by SIGKILL."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            PR_SET_PDEATHSIG = 1
            libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
        except (OSError, AttributeError):  # pragma: no cover - no prctl: the watchdog below still works
            pass
    if os.getppid() != parent_pid:  # the parent died before the line above
        os._exit(1)

    def watch() -> None:  # portable fallback: the parent's pid changes when it dies (re-parenting)
        while True:
            time.sleep(0.5)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, name="parent-watchdog", daemon=True).start()


class Interrupted(KeyboardInterrupt):
    """Raised in the main thread by SIGINT or SIGTERM while :func:`interruptible` is active;
    ``signum`` says which (exit status 128 + signum)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


# Where an exception raised by a signal handler is lost or changed: a finaliser (``__del__``: "Exception
# ignored in"), a ctypes callback (llvmlite's object cache: "Exception ignored on calling ctypes callback
# function"), a C library's import or call that turns it into another error (mujoco's module init gives
# "ImportError: initialization failed", a ctypes argument's conversion "ArgumentError"). Seen with numba
# compiling and the GL context starting while ``train`` was interrupted: the run went on and exited 0.
_SWALLOWING_PACKAGES = ("llvmlite", "numba", "mujoco", "OpenGL", "ctypes", "importlib")
_REDELIVER_S = 0.02


def _package(filename: str) -> str:
    """The top-level package of a source file: the folder after ``site-packages`` (or
    ``dist-packages``), else (the standard library) the file's own folder."""
    parts = filename.replace("\\", "/").split("/")
    for i, p in enumerate(parts[:-1]):
        if p in ("site-packages", "dist-packages"):
            return parts[i + 1]
    return parts[-2] if len(parts) > 1 else ""


def swallowing_context(frame: Any) -> bool:
    """True if an exception raised in ``frame`` (a signal handler's second argument) could be lost or
    turned into another error on its way out: some frame of its stack is a finaliser, or runs in one of
    the packages above (a C library's callback, conversion or module initialisation)."""
    while frame is not None:
        code = frame.f_code
        if code.co_name == "__del__" or code.co_filename.startswith("<frozen importlib"):
            return True
        if _package(code.co_filename) in _SWALLOWING_PACKAGES:
            return True
        frame = frame.f_back
    return False


@contextlib.contextmanager
def interruptible() -> Iterator[None]:
    """SIGINT and SIGTERM raise :class:`Interrupted` in the main thread (so ``finally`` blocks run:
    workers are stopped, what was written stays); a second signal is ignored while the first one's
    clean-up runs. A signal that arrives where the exception would be lost (:func:`swallowing_context`:
    numba compiling, a finaliser, a C library's callback) is sent again to the main thread every 20 ms
    until it lands where it propagates; one still pending when the block ends is raised there. An
    error that leaves the block after the signal's ``Interrupted`` was raised is that interruption (a C
    extension turned it into another exception) and leaves as ``Interrupted``."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    sigs = (signal.SIGINT, signal.SIGTERM)
    main = threading.get_ident()
    # pending: the deferred signal (None: none); sent: re-sends made; active: False once the block ends;
    # raised: the signal whose Interrupted the handler raised
    lock, state = threading.Lock(), types.SimpleNamespace(active=True, sent=0, pending=None, raised=None)

    def resend(signum: int) -> None:  # a timer thread: never after the block has ended
        with lock:
            if state.active:
                state.sent += 1
                signal.pthread_kill(main, signum)

    def handler(signum, frame):
        if not state.active:  # a re-sent signal that arrived while the block ends: already acted on
            return
        if swallowing_context(frame):
            if state.pending is None:
                state.pending = signum
            t = threading.Timer(_REDELIVER_S, resend, (state.pending,))
            t.daemon = True
            t.start()
            return
        for s in sigs:
            signal.signal(s, signal.SIG_IGN)
        state.pending = None
        state.raised = signum
        raise Interrupted(signum)

    old = {s: signal.signal(s, handler) for s in sigs}
    try:
        try:
            yield
        except Exception as exc:
            # raised inside a C extension's call (pybind11 converting an argument: mujoco's specs), the
            # Interrupted comes out as another error ("incompatible function arguments"): it is the signal's
            if state.raised is not None:
                raise Interrupted(state.raised) from exc
            raise
        if state.pending is not None:  # sent again, but the block ended first
            for s in sigs:
                signal.signal(s, signal.SIG_IGN)
            raise Interrupted(state.pending)
    finally:
        with lock:
            state.active = False
            sent = state.sent
        if sent:  # a signal re-sent before now is delivered on this sleep's return, to this block's handler
            time.sleep(0.002)
        for s, h in old.items():
            signal.signal(s, h)
