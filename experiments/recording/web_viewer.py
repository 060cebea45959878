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


def _port_open(port: int, host: str) -> bool:
    try:
        with socket.create_connection((host, port), timeout=0.25):
            return True
    except OSError:
        return False


class WebViewer:
    """Rerun's web viewer and its gRPC proxy (``rerun --serve-web``) in a child process, bound to
    127.0.0.1 only: open :attr:`url` in a browser on this machine (from another one, forward both
    ports, ``ssh -L 9090:127.0.0.1:9090 -L 9876:127.0.0.1:9876 HOST``); stream a recording to
    :attr:`grpc_url` (``Recorder(connect=...)``). The proxy keeps what it received for viewers that
    connect later (up to ``server_memory_limit``); ``recordings`` are ``.rrd`` files it loads and
    serves. Stop it with :meth:`close` (or use it as a context manager); on Linux it also stops when
    this process dies, however it dies (the server is the real ``rerun`` binary, not its Python
    wrapper, and gets SIGTERM from the kernel when its parent is gone).

    Raises ``ValueError`` if a port is taken and ``RuntimeError`` if the server does not start.
    """

    HOST = "127.0.0.1"

    def __init__(self, web_port: int = 9090, grpc_port: int = 9876, *, server_memory_limit: str = "1GiB",
                 start_timeout_s: float = 30.0, recordings: tuple = ()) -> None:
        ports = {"web_port": web_port, "grpc_port": grpc_port}
        for name, port in ports.items():
            if isinstance(port, bool) or not isinstance(port, (int, np.integer)) or not 1 <= port <= 65535:
                raise ValueError(f"{name} must be a whole number in 1..65535; got {port!r}")
        if web_port == grpc_port:
            raise ValueError(f"web_port and grpc_port must differ; both are {web_port}")
        for name, port in ports.items():
            if not _port_free(int(port), self.HOST):
                raise ValueError(f"port {port} on {self.HOST} is in use; choose another ({name})")
        files = [os.fspath(r) for r in recordings]
        for f in files:
            if not os.path.isfile(f):
                raise FileNotFoundError(f"recording {f!r} does not exist (write one with 'python -m experiments "
                                        f"run' or 'visualize --out FILE.rrd')")
        self.web_port, self.grpc_port = int(web_port), int(grpc_port)
        self.proc = None
        self._log = tempfile.TemporaryFile()
        cmd = [_rerun_executable(), "--serve-web", "--bind", self.HOST, "--port", str(self.grpc_port),
               "--web-viewer-port", str(self.web_port), "--server-memory-limit", server_memory_limit, *files]
        if sys.platform.startswith("linux"):
            cmd = [sys.executable, "-c", _EXEC_WITH_PARENT, str(os.getpid()), *cmd]
        self.proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=self._log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + float(start_timeout_s)
        while not (_port_open(self.grpc_port, self.HOST) and _port_open(self.web_port, self.HOST)):
            if self.proc.poll() is not None or time.monotonic() > deadline:
                log = self.output()
                self.close()
                raise RuntimeError(f"the Rerun web viewer did not start on {self.HOST}:{self.web_port} "
                                   f"(gRPC {self.grpc_port}); its output ends: {log[-500:]!r}")
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
        return self.proc.poll() is None

    def output(self) -> str:
        """What the server printed so far."""
        self._log.flush()
        self._log.seek(0)
        return self._log.read().decode(errors="replace")

    def wait(self, seconds: float | None = None) -> None:
        """Serve for ``seconds`` (forever when None; Ctrl-C raises KeyboardInterrupt). Raises
        ``RuntimeError`` if the server stops by itself."""
        deadline = math.inf if seconds is None else time.monotonic() + float(seconds)
        while time.monotonic() < deadline:
            if not self.running:
                raise RuntimeError(f"the Rerun web viewer stopped (exit {self.proc.returncode}); "
                                   f"its output ends: {self.output()[-500:]!r}")
            time.sleep(min(0.2, max(0.0, deadline - time.monotonic())))

    def close(self) -> None:
        """Stop the server (idempotent)."""
        if getattr(self, "proc", None) is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if getattr(self, "_log", None) is not None and not self._log.closed:
            self._log.close()

    def __enter__(self) -> "WebViewer":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:
            pass
