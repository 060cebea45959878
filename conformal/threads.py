"""BLAS thread limits for the per-frame hot paths.

numpy's OpenBLAS starts one thread per core. The per-frame products here are small (the remapping's
angular sum is ~6 M multiply-adds), so a second BLAS thread gains little on an idle machine and,
when anything else runs on the other core, the two threads fight for it: on 2 cores with a second
job the environment fell from ~150 to 22-45 steps/s (measured on this project's 2-core machines). Hot paths
therefore run their BLAS calls inside :func:`blas_threads` (``threadpoolctl``), which limits the
BLAS pools to one thread for the duration of the call and restores the caller's setting after it,
so a user's own numpy/torch work elsewhere in the process keeps its threads.
"""

from __future__ import annotations

import sys
import threading
from contextlib import AbstractContextManager

from threadpoolctl import ThreadpoolController

__all__ = ["blas_threads"]

_lock = threading.Lock()
_controller: ThreadpoolController | None = None
_n_libraries = -1


def _blas_controller() -> ThreadpoolController:
    """One scan of the loaded BLAS libraries (about 1 ms), redone only when new ones were loaded."""
    global _controller, _n_libraries
    n = len(sys.modules)  # a new import may have loaded another BLAS (scipy, torch)
    with _lock:
        if _controller is None or n != _n_libraries:
            _controller = ThreadpoolController().select(user_api="blas")
            _n_libraries = n
        return _controller


class _BlasLimit(AbstractContextManager):
    """At most ``n`` threads in each of ``libraries`` (threadpoolctl's controllers) inside the block,
    each library's own setting again after it: threadpoolctl's ``limit`` without its bookkeeping
    (~12 us a use instead of ~35 us, for the two OpenBLAS copies numpy and scipy load)."""

    __slots__ = ("_libraries", "_n", "_previous")

    def __init__(self, libraries, n: int) -> None:
        self._libraries, self._n = libraries, n
        self._previous: tuple[int, ...] = ()

    def __enter__(self) -> _BlasLimit:
        self._previous = tuple(lib.num_threads for lib in self._libraries)
        for lib, before in zip(self._libraries, self._previous):
            if before > self._n:
                lib.set_num_threads(self._n)
        return self

    def __exit__(self, *exc) -> None:
        for lib, before in zip(self._libraries, self._previous):
            if before > self._n:
                lib.set_num_threads(before)


def blas_threads(n: int = 1) -> AbstractContextManager:
    """A context manager in which the process's BLAS libraries use at most ``n`` threads.

    Each library's previous setting is restored on exit. Costs about 12 us per use. ``n`` must be a
    positive integer.
    """
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"n must be a positive integer number of threads; got {n!r}")
    return _BlasLimit(_blas_controller().lib_controllers, n)
