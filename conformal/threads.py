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
from contextlib import AbstractContextManager, nullcontext

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


def blas_threads(n: int = 1) -> AbstractContextManager:
    """A context manager in which the process's BLAS libraries use at most ``n`` threads.

    Each library's previous setting is restored on exit (threadpoolctl's ``limit``, which also hands
    OpenBLAS's process-wide pool back for other Python threads to limit). A library already at ``n``
    threads or fewer is left as it is. Costs about 35 us per use. ``n`` must be a positive integer.
    """
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"n must be a positive integer number of threads; got {n!r}")
    controller = _blas_controller()
    now = [lib.num_threads for lib in controller.lib_controllers]
    if all(k <= n for k in now):
        return nullcontext()
    return controller.limit(limits={lib.filepath: min(n, k) for lib, k in zip(controller.lib_controllers, now)})
