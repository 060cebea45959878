"""numba's threads in the saccade model's parallel loops (``models._plan_kernels.kernel_threads``):
one head's plan runs on one thread, so that several env processes (SB3's ``SubprocVecEnv``, Ray
workers) on as many cores do not contend for each other's cores; thousands of worlds use them all.
The speed this buys is measured in ``benchmarks/env.py`` (contention); here, the setting itself."""

import numba
import numpy as np
import pytest

import envs
import models
from models import _plan_kernels as K

PARALLEL = [K.angles, K.command_rows, K.rates, K.signals, K.profile_marks, K.profile_values]
MULTI = numba.config.NUMBA_NUM_THREADS >= 2  # with one thread in all, no limit can be seen


@numba.njit(parallel=True)
def _threads_seen(out):  # each row: the number of threads the parallel region was given
    for i in numba.prange(out.shape[0]):
        out[i] = numba.get_num_threads()


_probe = K._par(_threads_seen.py_func)
_probe.kernel = _threads_seen  # compiled here, not cached on disk


@pytest.mark.parametrize("n, expected", [(1, 1), (K.SACCADES_PER_THREAD * 2 - 1, 1),
                                         (K.SACCADES_PER_THREAD * 2, 2), (10**6, None)])
def test_threads_in_the_loop_follow_the_rows(n, expected):
    full = numba.get_num_threads()
    expected = full if expected is None else min(expected, full)
    out = np.zeros(n, np.int64)
    _probe(out)
    assert (out == expected).all()
    assert numba.get_num_threads() == full  # restored


def test_limit_is_restored_after_an_error():
    full = numba.get_num_threads()
    with pytest.raises(RuntimeError, match="inside"):
        with K.kernel_threads(1) as k:
            assert k == 1 and numba.get_num_threads() == 1
            raise RuntimeError("inside")
    assert numba.get_num_threads() == full


@pytest.mark.skipif(not MULTI, reason="numba has one thread on this machine: nothing to limit")
def test_single_env_step_runs_every_parallel_loop_on_one_thread(monkeypatch):
    """Every parallel loop the single env's step calls sees one numba thread (numba's default here
    is one per core), and the setting is back to the default after the step."""
    full = numba.get_num_threads()
    assert full >= 2
    seen = []
    for wrapper in PARALLEL:
        kernel = wrapper.kernel

        def record(*args, _kernel=kernel, _name=wrapper.__name__):
            seen.append((_name, numba.get_num_threads()))
            return _kernel(*args)

        monkeypatch.setattr(wrapper, "kernel", record)
    env = envs.BinocularSaccadeEnv(image_size=32)
    env.reset(seed=0)
    env.step(np.array([0.3, 0.1], np.float32))
    env.close()
    names = {name for name, _ in seen}
    assert {"angles", "signals"} <= names  # the plan's trajectory and its eye-position signal ran
    assert all(k == 1 for _, k in seen), seen
    assert numba.get_num_threads() == full


@pytest.mark.skipif(not MULTI, reason="numba has one thread on this machine: nothing to use in parallel")
def test_many_worlds_use_every_thread(monkeypatch):
    full = numba.get_num_threads()
    seen = []
    kernel = K.command_rows.kernel  # the command tables' loop

    def record(*args):
        seen.append(numba.get_num_threads())
        return kernel(*args)

    monkeypatch.setattr(K.command_rows, "kernel", record)
    head = models.Head("dots", 32, seed=0)
    planner, settled = models.BatchedPlanner(head, 256), models.SettledReset(head)
    for i in range(256):
        settled.apply(head, i)
        planner.take_reset(i)
    rng = np.random.default_rng(0)
    plans, _ = planner.plan(np.arange(256), rng.uniform(-0.2, 0.2, (256, 2)), np.ones(256))
    planner.commands(plans)
    assert seen and all(k == full for k in seen)


@pytest.mark.skipif(not MULTI, reason="numba has one thread in all")
def test_the_limit_can_be_lifted_and_restored():
    """``models.limit_plan_threads(False)``: a one-head loop runs on numba's whole setting; on again: one."""
    out = np.zeros(1, np.int64)
    assert models.limit_plan_threads(False) is True
    try:
        _probe(out)
        assert out[0] == numba.get_num_threads() >= 2
    finally:
        assert models.limit_plan_threads(True) is False
    _probe(out)
    assert out[0] == 1
    with pytest.raises(TypeError, match="True or False"):
        models.limit_plan_threads(1)
