"""Every wait says what it does; ETAs start after warm-up (issue 37, item 7).

The progress bar of a command opens only after its first units are done, so no rate or ETA can
include numba's compilation or MuJoCo's start; the first line on stderr names the warm-up stage.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from experiments.cli import Progress, stage

ROOT = Path(__file__).resolve().parents[1]
BAR = re.compile(r"(\d+)/(\d+) \[")


def test_stage_and_warmup_line_precede_the_bar(capsys):
    bar = Progress(10, desc="trials", unit="trial", warmup="warming up (compiling)")
    err = capsys.readouterr().err
    assert err == "trials: warming up (compiling)\n"  # a stage line, no 0/10 bar, no ETA
    bar.update(3)
    err = capsys.readouterr().err
    assert "3/10" in err and "?" in err  # opened at 3 done, with no rate yet: warm-up not in it
    bar.update(2)
    bar.close()
    assert "5/10" in capsys.readouterr().err


def test_resumed_bar_counts_from_what_was_done(capsys):
    with Progress(10, initial=4, desc="t", unit="u") as bar:
        bar.update(1)
    assert "5/10" in capsys.readouterr().err
    assert bar.n == 5


def test_no_progress_prints_nothing(capsys):
    with Progress(10, desc="t", unit="u", enabled=False) as bar:
        bar.update(10)
    stage("loading", enabled=False)
    assert capsys.readouterr().err == ""
    assert bar.n == 10


def test_without_warmup_the_bar_opens_at_once(capsys):
    Progress(5, desc="t", unit="u", warmup=None).close()
    assert "0/5" in capsys.readouterr().err


@pytest.mark.slow
def test_run_quick_names_its_warmup_before_any_bar(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.run([sys.executable, "-m", "experiments", "run", "--quick", "--workers", "1",
                           "--no-recording", "--formats", "png", "--out", str(tmp_path / "r")],
                          capture_output=True, text=True, env=env, cwd=ROOT, timeout=600)
    assert proc.returncode == 0, proc.stderr
    lines = [s.strip() for s in re.split(r"[\r\n]", proc.stderr) if s.strip()]
    bars = [i for i, s in enumerate(lines) if BAR.search(s)]
    assert bars, proc.stderr
    assert "warming up" in lines[0], lines[:3]
    assert bars[0] > 0
    first = BAR.search(lines[bars[0]])
    assert int(first.group(1)) > 0  # the bar opens after the first trials are done...
    assert "?" in lines[bars[0]]  # ...and shows no rate until more are
    assert any(s.startswith("writing the summary") for s in lines[bars[-1]:])
