"""Suite-wide pytest hooks: parallel workers, numba's cache warmed once, the ``adversarial`` counts.

The markers (``slow``, ``install``, ``warp``, ``readme``, ``adversarial``) are declared in
``pyproject.toml`` (``[tool.pytest.ini_options] markers``); the README's "Tests" section says what
each means and which command leaves which out. A test over ~2 s on 2 cores carries
``@pytest.mark.slow`` where it is written.

* **Workers.** ``pyproject.toml`` runs the suite on pytest-xdist workers (``-n auto``: one per CPU,
  at most 8; ``-n 0`` runs in one process) with ``--dist loadgroup``: the tests of a file that
  defines a module-scoped fixture (a trained policy, a study's table, the README's scratch folder
  whose blocks run in order) are sent to one worker together, so no fixture is built twice; the
  others are spread one by one. The longest work goes first (the groups, largest first, then the
  ``slow`` tests), so that no long test is left for the end while the other worker idles.
* **numba.** Before any worker starts, the compiled kernels an env episode runs are compiled once
  into numba's on-disk cache (or read back from it), so their compilation (about 30 s cold) is
  not charged to whichever test first touches a kernel, nor paid by every worker.
* **Collection.** A file whose module mark (``pytestmark = pytest.mark.warp``) the ``-m`` expression
  excludes whatever else its tests carry is not imported (``deselects_whole_file``).
* **Adversarial counts.** Every hostile-input test (NaN, inf, wrong types and shapes, zero,
  negative, huge and non-integer values, corrupt files, bad CLI options) is marked
  ``@pytest.mark.adversarial``; a test that tries many hostile calls in one item (the public-API
  walk of ``tests/test_adversarial_api.py``) reports them through the ``hostile_calls`` fixture.
  The terminal summary says how many such cases ran and how many passed.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import itertools
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import pytest

import models  # noqa: F401  (first: it picks MuJoCo's off-screen GL backend before anything loads mujoco)

MAX_WORKERS = 8  # -n auto: one worker per CPU, at most this many (each holds MuJoCo, numba and torch)

_ADVERSARIAL = {"passed": 0, "failed": 0, "skipped": 0}
_CALLS = {"tried": 0, "refused": 0}
_WARM: dict[str, str] = {}


# ---------------------------------------------------------------------------------------------- workers


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_auto_num_workers(config: pytest.Config) -> int:
    """``-n auto``: one worker per CPU this process may use (not per physical core: a 2-vCPU machine
    gets 2), at most ``MAX_WORKERS``."""
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return max(1, min(cpus, MAX_WORKERS))


def _is_worker(config: pytest.Config) -> bool:
    return hasattr(config, "workerinput")


def _shares_a_fixture(item: pytest.Item) -> bool:
    """The test uses a fixture built once for several tests (module, class, package or session scope)."""
    info = getattr(item, "_fixtureinfo", None)
    return info is not None and any(
        defs and defs[-1].scope != "function" and defs[-1].baseid != ""  # pytest's own fixtures aside
        for name, defs in info.name2fixturedefs.items() if name in item.fixturenames)


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node) -> None:
    """The controller tells each worker where to write which tests share a fixture."""
    node.workerinput["fixture_groups"] = node.config._fixture_groups_dir


@pytest.hookimpl(tryfirst=True)
def pytest_collection_finish(session: pytest.Session) -> None:
    """A worker writes which of its tests share a fixture (node id -> file), before pytest-xdist
    reports its collection to the controller."""
    folder = getattr(session.config, "workerinput", {}).get("fixture_groups")
    if folder:
        groups = {i.nodeid: i.nodeid.split("::", 1)[0] for i in session.items if _shares_a_fixture(i)}
        slow = [i.nodeid for i in session.items if i.get_closest_marker("slow") is not None]
        path = Path(folder) / f"{session.config.workerinput['workerid']}.json"
        path.with_suffix(".tmp").write_text(json.dumps({"groups": groups, "slow": slow}))
        path.with_suffix(".tmp").replace(path)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log):
    """``--dist loadgroup``: the tests that share a fixture of their file go to one worker together
    (so the fixture is built once, and the README's blocks run in order in one folder); the others
    are spread one by one. (pytest-xdist's own ``xdist_group`` marks do not group under pytest 9,
    whose node ids its worker can no longer rename.)"""
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadScopeScheduling

    folder = Path(config._fixture_groups_dir)

    class SharedFixtureScheduling(LoadScopeScheduling):
        groups: dict[str, str] | None = None
        slow: set[str] = set()

        def _read(self) -> None:
            if self.groups is None:  # every worker has collected (and written its file) by now
                self.groups = {}
                for f in folder.glob("*.json"):
                    written = json.loads(f.read_text())
                    self.groups.update(written["groups"])
                    self.slow = self.slow | set(written["slow"])

        def _split_scope(self, nodeid: str) -> str:
            self._read()
            assert self.groups is not None
            return self.groups.get(nodeid, nodeid)

        def schedule(self) -> None:
            """The longest work first, so that no long test is left for the end while the other
            workers idle: the groups (largest first, as ``LoadScopeScheduling`` orders them), then the
            slow tests, then the rest, each in collection order. Only the queue of work units is
            reordered (a worker runs the tests it is sent by their index in its own collection)."""
            first_time = self.collection is None
            super().schedule()
            if first_time and self.workqueue:
                def early(scope: str) -> bool:
                    return len(self.workqueue[scope]) > 1 or scope in self.slow

                order = [s for s in self.workqueue if early(s)] + [s for s in self.workqueue if not early(s)]
                self.workqueue = type(self.workqueue)((s, self.workqueue[s]) for s in order)

    return SharedFixtureScheduling(config, log)


def pytest_itemcollected(item: pytest.Item) -> None:
    """Marks each test as it is collected."""
    if " at 0x" in item.nodeid:
        raise pytest.UsageError(f"{item.nodeid}: a test id holds a memory address, which differs between "
                                "pytest-xdist workers; give the parametrization ids without it")


# ------------------------------------------------------------------------------------------- collection

_MODULE_MARK = re.compile(r"^pytestmark\s*=\s*(.*)$", re.M)


def deselects_whole_file(source: str, markexpr: str) -> bool:
    """Whether ``-m markexpr`` leaves out every test of a file whose source is ``source``: true where the
    file marks all its tests (``pytestmark = pytest.mark.warp``) and the expression is false for those
    marks together with any combination of the other marks the expression names (no other mark can
    change its value)."""
    if not markexpr:
        return False
    line = _MODULE_MARK.search(source)
    marks = set(re.findall(r"pytest\.mark\.(\w+)", line.group(1))) if line else set()
    if not marks:
        return False
    try:  # pytest's own parser of -m (a private module: where it moves, every file is imported as before)
        from _pytest.mark.expression import Expression

        expr = Expression.compile(markexpr)
    except Exception:  # noqa: BLE001 - a bad -m is pytest's to report (its usage error), not this hook's
        return False
    named = set(re.findall(r"[A-Za-z_]\w*", markexpr)) - {"and", "or", "not", "True", "False"}
    others = sorted(named - marks)
    for extra in itertools.product((False, True), repeat=len(others)):
        on = marks | {m for m, o in zip(others, extra) if o}
        if expr.evaluate(lambda name, /, **kw: name in on):
            return False
    return True


def pytest_ignore_collect(collection_path: Path, config: pytest.Config) -> bool | None:
    """A test file every test of which ``-m`` leaves out by its module mark is not imported: the fast
    subset (``-m "not slow and not install and not warp and not readme"``) does not pay the gpu extra's
    imports (MuJoCo Warp, Warp, torch: ~4 s in every worker) only to deselect those files' tests."""
    name = collection_path.name
    if not (name.startswith("test_") and name.endswith(".py")):
        return None
    try:
        source = collection_path.read_text()
    except OSError:
        return None
    return True if deselects_whole_file(source, config.getoption("markexpr") or "") else None


# ------------------------------------------------------------------------------------------------ numba


def _kernel_sources() -> list[Path]:
    """The source files of the compiled kernels (numba's cache is keyed by each file's time stamp;
    ``conformal.maps`` is compiled inline into ``conformal.kernels``' kernels)."""
    names = ("conformal.kernels", "conformal.maps", "models._plan_kernels", "models.linear_tail", "envs.tasks")
    return [Path(importlib.util.find_spec(n).origin) for n in names]


def _warm_stamp() -> Path:
    """A file in numba's cache folder named for these kernel sources, numba and Python: present
    when this warm-up already ran against them."""
    import numba

    parts = [numba.__version__, sys.version]
    for path in _kernel_sources():
        st = path.stat()
        parts.append(f"{path}:{st.st_mtime_ns}:{st.st_size}")
    key = hashlib.sha256("|".join(parts).encode()).hexdigest()[:16]
    folder = os.environ.get("NUMBA_CACHE_DIR") or _kernel_sources()[0].parent / "__pycache__"
    return Path(folder) / f"tests-warm-{key}"


#: The two short episodes of the warm-up: between them, every compiled kernel an env runs.
WARM_EPISODES = ({"action_mode": "cell"}, {"grayscale": True, "pooled_remap": True, "vergence": True})


def warm_part(i: int) -> None:
    """Part ``i`` of the warm-up: 0 and 1 the episodes of ``WARM_EPISODES`` (``BinocularSaccade-v0`` at
    32 px, reset and two steps); 2 the batched planner's parallel plan kernels of four worlds, without
    and with endpoint noise, and a plan's velocities."""
    if i < len(WARM_EPISODES):
        import gymnasium as gym

        import envs  # noqa: F401  (registers the env)

        env = gym.make("BinocularSaccade-v0", image_size=32, **WARM_EPISODES[i])
        try:
            env.reset(seed=0)
            env.action_space.seed(0)
            for _ in range(2):
                env.step(env.action_space.sample())
        finally:
            env.close()
        return
    import numpy as np

    for kw in ({}, {"endpoint_noise": 0.15}):
        head = models.Head("dots", 16, seed=0, **kw)
        try:
            planner = models.BatchedPlanner(head, 4)
            for w in range(4):
                head.reset(seed=11 + w)
                planner.take_reset(w)
            plans, _ = planner.plan(np.arange(4), np.full((4, 2), 0.2), np.ones(4))
            planner.commands(plans)
            plan = head.plan_saccade(0.2, 0.1)
            plan.velocities(plan.onset_ms + np.arange(5.0))
        finally:
            head.close()


def warm_numba() -> None:
    """Compile (or read back from numba's on-disk cache) the kernels the tests run: retina pooling,
    DPFT, point and pooled remapping maps, prediction errors, the saccade and vergence plans (single
    and batched), the gaze errors. Parts 1 and 2 of ``warm_part`` run in child processes beside part 0
    (numba compiles on one thread; a kernel two parts touch is compiled twice, and numba's cache
    files are replaced atomically): about 25 s cold on 2 cores, where the kernels were otherwise
    compiled inside the first tests that touched them, on both workers."""
    here = Path(__file__).resolve().parent
    path = os.pathsep.join([str(here.parent), str(here), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    children = [subprocess.Popen([sys.executable, "-c", "import sys, conftest; conftest.warm_part(int(sys.argv[1]))",
                                  str(i)], env={**os.environ, "PYTHONPATH": path}, stdout=subprocess.DEVNULL,
                                 stderr=subprocess.PIPE, text=True) for i in (1, 2)]
    try:
        warm_part(0)
    finally:
        errors = [(c.communicate()[1], c.returncode) for c in children]
    for i, (err, rc) in enumerate(errors, start=1):
        if rc != 0:
            raise RuntimeError(f"the warm-up's part {i} failed: {err.strip().splitlines()[-1:] or rc}")


@pytest.hookimpl(trylast=True)  # after the terminal reporter is set up
def pytest_configure(config: pytest.Config) -> None:
    """Warm numba's cache once per run, in the process that starts the workers (or runs the tests)."""
    if _is_worker(config):
        return
    config._fixture_groups_dir = tempfile.mkdtemp(prefix="pytest-fixture-groups-")
    if config.option.collectonly or config.option.help or config.option.version:
        return
    try:
        stamp = _warm_stamp()
        if stamp.exists():
            _WARM["numba"] = "kernels already cached (warm-up skipped)"
            return
        reporter = config.pluginmanager.get_plugin("terminalreporter")
        if reporter is not None:
            reporter.write_line("numba: compiling the kernels into its on-disk cache, once (about 30 s the first time)")
        t0 = time.perf_counter()
        warm_numba()
        _WARM["numba"] = f"kernels compiled or read back in {time.perf_counter() - t0:.1f} s"
        stamp.parent.mkdir(parents=True, exist_ok=True)
        for old in stamp.parent.glob("tests-warm-*"):
            old.unlink(missing_ok=True)
        stamp.touch()
    except OSError as e:  # a read-only cache folder: the tests compile what they need
        _WARM["numba"] = f"warm-up stamp not written ({e})"
    except Exception as e:  # noqa: BLE001  (the tests that need the kernels will report it themselves)
        warnings.warn(f"numba warm-up failed: {type(e).__name__}: {e}", stacklevel=1)
        _WARM["numba"] = f"warm-up failed: {type(e).__name__}: {e}"


def pytest_unconfigure(config: pytest.Config) -> None:
    folder = getattr(config, "_fixture_groups_dir", None)
    if folder and not _is_worker(config):
        shutil.rmtree(folder, ignore_errors=True)


def pytest_report_header(config: pytest.Config) -> str | None:
    return f"numba: {_WARM['numba']}" if "numba" in _WARM else None


# ------------------------------------------------------------------------------------------ adversarial


class HostileCalls:
    """Counts the hostile calls one test item makes (``add(tried, refused)``); the counts travel in
    the test's report, so they add up across pytest-xdist workers."""

    def __init__(self, node: pytest.Item) -> None:
        self._node = node

    def add(self, tried: int, refused: int) -> None:
        self._node.user_properties.append(("hostile_calls", (int(tried), int(refused))))


@pytest.fixture
def hostile_calls(request: pytest.FixtureRequest) -> HostileCalls:
    return HostileCalls(request.node)


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    if report.when == "call":
        for name, value in report.user_properties:
            if name == "hostile_calls":
                _CALLS["tried"] += value[0]
                _CALLS["refused"] += value[1]
    if "adversarial" not in report.keywords:
        return
    if report.when == "call" or (report.when == "setup" and report.outcome != "passed"):
        _ADVERSARIAL[report.outcome] = _ADVERSARIAL.get(report.outcome, 0) + 1


def pytest_terminal_summary(terminalreporter, exitstatus, config) -> None:
    n = sum(_ADVERSARIAL.values())
    if n:
        terminalreporter.write_line(
            f"adversarial inputs: {n} cases tried, {_ADVERSARIAL['passed']} passed, "
            f"{_ADVERSARIAL['failed']} failed, {_ADVERSARIAL['skipped']} skipped")
    if _CALLS["tried"]:
        terminalreporter.write_line(
            f"public-API walk: {_CALLS['tried']} hostile calls, {_CALLS['refused']} refused with a clear error")
