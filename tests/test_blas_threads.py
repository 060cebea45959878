"""``conformal.blas_threads``: the BLAS libraries at most n threads inside the block, each library's own
setting again after it (an error inside, a nested block), read back through threadpoolctl itself."""

import pytest
from threadpoolctl import threadpool_info, threadpool_limits

import conformal as C


def _blas() -> list[int]:
    return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]


def test_limit_inside_and_each_setting_restored():
    if not _blas():
        pytest.skip("no BLAS library loaded")
    with threadpool_limits(limits=2, user_api="blas"):  # a known setting to return to (a user's own)
        before = _blas()
        with C.blas_threads(1):
            assert _blas() == [1] * len(before)
            with C.blas_threads(1):
                assert _blas() == [1] * len(before)
            assert _blas() == [1] * len(before)  # the inner block restores what it found: the outer limit
        assert _blas() == before
        with pytest.raises(RuntimeError, match="inside"):
            with C.blas_threads(1):
                raise RuntimeError("inside")
        assert _blas() == before
        with C.blas_threads(64):  # a limit above the setting leaves it as it is
            assert _blas() == before


def test_another_python_thread_can_limit_after_this_one():
    """OpenBLAS has one process-wide pool, which threadpoolctl lets one Python thread at a time set: a
    limit must hand it back on exit, or a later limit in another thread silently does nothing. (The
    pools are set to 2 threads first, and released, so that the test limits something under the
    suite's one-thread workers too.)"""
    import threading

    from threadpoolctl import OpenBLASController, ThreadpoolController

    libs = ThreadpoolController().select(user_api="blas").lib_controllers
    if not libs:
        pytest.skip("no BLAS library loaded")
    before = [lib.num_threads for lib in libs]
    try:
        for lib in libs:
            lib.set_num_threads(2)
        OpenBLASController.clear_controlling_thread()
        with C.blas_threads(1):
            pass
        seen: list[list[int]] = []

        def other() -> None:
            with C.blas_threads(1):
                seen.append(_blas())

        t = threading.Thread(target=other)
        t.start()
        t.join()
        assert seen == [[1] * len(libs)]
        assert _blas() == [2] * len(libs)
    finally:
        for lib, n in zip(libs, before):
            lib.set_num_threads(n)
        OpenBLASController.clear_controlling_thread()
