"""Rerun's web viewer and gRPC proxy in a child process on 127.0.0.1: :class:`WebViewer`."""

from __future__ import annotations

import math
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.parse
from typing import IO

import numpy as np


def _rerun_executable() -> str:
    """The ``rerun`` binary of the installed rerun-sdk (not its Python wrapper script, so that
    terminating it stops the server)."""
    if os.environ.get("RERUN_CLI_PATH"):
        return os.environ["RERUN_CLI_PATH"]
    try:
        import rerun_cli

        base = os.path.dirname(rerun_cli.__file__)
        for name in ("rerun", "rerun.exe", os.path.join("Rerun.app", "Contents", "MacOS", "Rerun")):
            if os.path.isfile(os.path.join(base, name)):
                return os.path.join(base, name)
    except ImportError:
        pass
    found = shutil.which("rerun")
    if found:
        return found
    raise FileNotFoundError("the rerun executable was not found; install rerun-sdk (pip install rerun-sdk)")


# Started in the child before exec: it gets SIGTERM when this process dies (Linux), so a killed
# ``visualize --serve`` does not leave the server behind.
_EXEC_WITH_PARENT = (
    "import ctypes, os, signal, sys\n"
    "try:\n"
    "    ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG\n"
    "except Exception:\n"
    "    pass\n"
    "if os.getppid() != int(sys.argv[1]):\n"
    "    sys.exit(1)\n"
    "os.execv(sys.argv[2], sys.argv[2:])\n"
)


def _port_free(port: int, host: str) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        try:
            s.bind((host, port))
        except OSError:
            return False
    return True


def _free_port(host: str, avoid: tuple[int, ...] = ()) -> int:
    """A port the system says is free on ``host`` now (bound to port 0, then released)."""
    while True:
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
            s.bind((host, 0))
            port = s.getsockname()[1]
        if port not in avoid:
            return port


def _listening_inodes(port: int) -> set[int] | None:
    """Inodes of the TCP sockets listening on ``port`` (Linux ``/proc/net/tcp``, ``tcp6``); None
    where that cannot be read."""
    found, read_any = set(), False
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            with open(table) as f:
                lines = f.read().splitlines()[1:]
        except OSError:
            continue
        read_any = True
        for line in lines:
            parts = line.split()
            if len(parts) > 9 and parts[3] == "0A" and int(parts[1].rsplit(":", 1)[1], 16) == port:
                found.add(int(parts[9]))
    return found if read_any else None


def _socket_inodes(pid: int) -> set[int] | None:
    """Inodes of the sockets process ``pid`` holds (Linux ``/proc/PID/fd``); None where unreadable."""
    try:
        links = [os.readlink(f"/proc/{pid}/fd/{fd}") for fd in os.listdir(f"/proc/{pid}/fd")]
    except OSError:
        return None
    return {int(x[8:-1]) for x in links if x.startswith("socket:[")}


def _owns_port(pid: int, port: int) -> bool | None:
    """Whether process ``pid`` is the one listening on ``port``; None where the system does not say."""
    listening, mine = _listening_inodes(port), _socket_inodes(pid)
    if listening is None or mine is None:
        return None
    return bool(listening & mine)


def _port_open(port: int, host: str) -> bool:
    try:
        with socket.create_connection((host, port), timeout=0.25):
            return True
    except OSError:
        return False


class _PortTaken(ValueError):
    """Another process took a port between the check and the server's start."""


class WebViewer:
    """Rerun's web viewer and its gRPC proxy (``rerun --serve-web``) in a child process, bound to
    127.0.0.1 only: open :attr:`url` in a browser on this machine (from another one, forward both
    ports, ``ssh -L 9090:127.0.0.1:9090 -L 9876:127.0.0.1:9876 HOST``); stream a recording to
    :attr:`grpc_url` (``Recorder(connect=...)``). The proxy keeps what it received for viewers that
    connect later (up to ``server_memory_limit``); ``recordings`` are ``.rrd`` files it loads and
    serves. Stop it with :meth:`close` (or use it as a context manager); on Linux it also stops when
    this process dies, however it dies (the server is the real ``rerun`` binary, not its Python
    wrapper, and gets SIGTERM from the kernel when its parent is gone).

    A port of 0 picks a free one (:attr:`web_port`, :attr:`grpc_port` say which). The address is
    known only once this server listens on both ports: on Linux the listening sockets are checked to
    be the child's own (``/proc``), so a server another process started on a port at the same moment
    is never advertised as this one. Raises ``ValueError`` naming the port if one is taken (before or
    during the start) and ``RuntimeError`` if the server does not start.
    """

    HOST = "127.0.0.1"

    def __init__(
        self,
        web_port: int = 9090,
        grpc_port: int = 9876,
        *,
        server_memory_limit: str = "1GiB",
        start_timeout_s: float = 30.0,
        recordings: tuple = (),
    ) -> None:
        ports = {"web_port": web_port, "grpc_port": grpc_port}
        for name, port in ports.items():
            if isinstance(port, bool) or not isinstance(port, (int, np.integer)) or not 0 <= port <= 65535:
                raise ValueError(f"{name} must be a whole number in 0..65535 (0: a free one); got {port!r}")
        if web_port == grpc_port and web_port != 0:
            raise ValueError(f"web_port and grpc_port must differ; both are {web_port}")
        for name, port in ports.items():
            if port and not _port_free(int(port), self.HOST):
                raise ValueError(f"port {port} on {self.HOST} is in use; choose another ({name}), or 0 for a free one")
        files = [os.fspath(r) for r in recordings]
        for f in files:
            if not os.path.isfile(f):
                raise FileNotFoundError(
                    f"recording {f!r} does not exist (write one with 'python -m experiments "
                    f"run' or 'visualize --out FILE.rrd')"
                )
        self.proc: subprocess.Popen[bytes] | None = None
        self._log: IO[bytes] | None = None
        tries = 5 if 0 in (web_port, grpc_port) else 1
        for attempt in range(tries):
            grpc = int(grpc_port) or _free_port(self.HOST, (int(web_port),))
            web = int(web_port) or _free_port(self.HOST, (grpc,))
            try:
                self._start(web, grpc, server_memory_limit, float(start_timeout_s), files)
                return
            except _PortTaken:
                if attempt == tries - 1 or (grpc_port and web_port):
                    raise
            except BaseException:
                self.close()
                raise

    def _start(self, web: int, grpc: int, memory: str, timeout_s: float, files: list[str]) -> None:
        """Start the server on these ports; return once *this* child listens on both (never on the word
        of another process's server that holds a port); :class:`_PortTaken` if one was taken."""
        self.web_port, self.grpc_port = web, grpc
        self._log = log_file = tempfile.TemporaryFile()
        cmd = [
            _rerun_executable(),
            "--serve-web",
            "--bind",
            self.HOST,
            "--port",
            str(grpc),
            "--web-viewer-port",
            str(web),
            "--server-memory-limit",
            memory,
            *files,
        ]
        if sys.platform.startswith("linux"):
            cmd = [sys.executable, "-c", _EXEC_WITH_PARENT, str(os.getpid()), *cmd]
        self.proc = proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=log_file, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + timeout_s
        names = {web: "web_port", grpc: "grpc_port"}
        while True:
            owned = [_owns_port(proc.pid, p) for p in (grpc, web)]
            if all(o is True for o in owned):
                return
            if None in owned and all(_port_open(p, self.HOST) for p in (grpc, web)):
                time.sleep(0.5)  # no /proc: a child that could not bind exits at once
                if proc.poll() is None:
                    return
            if proc.poll() is not None or time.monotonic() > deadline:
                log = self.output()
                taken = [p for p in (grpc, web) if _port_open(p, self.HOST) and owned[(grpc, web).index(p)] is not True]
                self.close()
                if taken:
                    raise _PortTaken(
                        f"port {taken[0]} on {self.HOST} is in use by another process; choose another "
                        f"({names[taken[0]]}), or 0 for a free one"
                    )
                raise RuntimeError(
                    f"the Rerun web viewer did not start on {self.HOST}:{web} "
                    f"(gRPC {grpc}); its output ends: {log[-500:]!r}"
                )
            time.sleep(0.05)

    @property
    def grpc_url(self) -> str:
        """Where a recording streams to (``Recorder(connect=...)``)."""
        return f"rerun+http://{self.HOST}:{self.grpc_port}/proxy"

    @property
    def url(self) -> str:
        """The page to open in a browser: the web viewer, connected to :attr:`grpc_url`."""
        return f"http://{self.HOST}:{self.web_port}/?url={urllib.parse.quote(self.grpc_url, safe='')}"

    @property
    def running(self) -> bool:
        assert self.proc is not None, "the constructor starts the server"
        return self.proc.poll() is None

    def output(self) -> str:
        """What the server printed so far."""
        if self._log is None or self._log.closed:
            return ""
        self._log.flush()
        self._log.seek(0)
        return self._log.read().decode(errors="replace")

    def wait(self, seconds: float | None = None) -> None:
        """Serve for ``seconds`` (forever when None; Ctrl-C raises KeyboardInterrupt). Raises
        ``RuntimeError`` if the server stops by itself."""
        deadline = math.inf if seconds is None else time.monotonic() + float(seconds)
        while time.monotonic() < deadline:
            if not self.running:
                assert self.proc is not None, "the constructor starts the server"
                raise RuntimeError(
                    f"the Rerun web viewer stopped (exit {self.proc.returncode}); "
                    f"its output ends: {self.output()[-500:]!r}"
                )
            time.sleep(min(0.2, max(0.0, deadline - time.monotonic())))

    def close(self) -> None:
        """Stop the server (idempotent)."""
        proc, log = getattr(self, "proc", None), getattr(self, "_log", None)
        if proc is not None and proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        if log is not None and not log.closed:
            log.close()

    def __enter__(self) -> WebViewer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:
            pass
