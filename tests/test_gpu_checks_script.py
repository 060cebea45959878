"""``benchmarks/gpu_checks.sh`` (the GPU checks of issue 38 in one run) stays runnable where no GPU is:
valid bash, and every test file and benchmark it names exists."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "benchmarks" / "gpu_checks.sh"


@pytest.mark.skipif(shutil.which("bash") is None, reason="needs bash")
def test_the_script_is_valid_bash():
    subprocess.run(["bash", "-n", str(SCRIPT)], check=True)


def test_every_file_it_runs_exists():
    text = SCRIPT.read_text()
    named = set(re.findall(r"\b((?:tests|benchmarks)/[\w/]+\.py)\b", text))
    assert {"tests/test_batched_physics.py", "benchmarks/batched.py", "benchmarks/planner.py"} <= named
    missing = sorted(p for p in named if not (ROOT / p).is_file())
    assert not missing, missing
