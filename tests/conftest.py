"""Suite-wide pytest hooks: the ``adversarial`` marker and its case count.

Every hostile-input case (NaN, inf, wrong types and shapes, zero, negative, huge and non-integer
values, corrupt files, bad CLI options) is one test item marked ``@pytest.mark.adversarial``; the
terminal summary reports how many such cases ran and how many passed.
"""

from __future__ import annotations

import pytest

import models  # noqa: F401  (first: it picks MuJoCo's off-screen GL backend before anything loads mujoco)

_ADVERSARIAL = {"passed": 0, "failed": 0, "skipped": 0}


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "adversarial: a hostile-input case (counted in the summary)")
    config.addinivalue_line("markers", "readme: runs a code block of README.md")


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
