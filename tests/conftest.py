"""Suite-wide pytest hooks: the ``adversarial`` case count.

The markers (``slow``, ``install``, ``warp``, ``readme``, ``adversarial``) are declared in
``pyproject.toml`` (``[tool.pytest.ini_options] markers``); the README's "Tests" section says what
each means and which command leaves which out.

Every hostile-input test (NaN, inf, wrong types and shapes, zero, negative, huge and non-integer
values, corrupt files, bad CLI options) is marked ``@pytest.mark.adversarial``; a test that tries
many hostile calls in one item (the public-API walk of ``tests/test_adversarial_api.py``) reports
them through the ``hostile_calls`` fixture. The terminal summary says how many such cases ran and
how many passed.
"""

from __future__ import annotations

import pytest

import models  # noqa: F401  (first: it picks MuJoCo's off-screen GL backend before anything loads mujoco)

_ADVERSARIAL = {"passed": 0, "failed": 0, "skipped": 0}
_CALLS = {"tried": 0, "refused": 0}


class HostileCalls:
    """Counts the hostile calls one test item makes (``add(tried, refused)``)."""

    def add(self, tried: int, refused: int) -> None:
        _CALLS["tried"] += tried
        _CALLS["refused"] += refused


@pytest.fixture
def hostile_calls() -> HostileCalls:
    return HostileCalls()


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
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
