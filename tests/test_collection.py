"""The suite's collection rule (``tests/conftest.py``): a file is left unimported only where ``-m``
excludes every test it could hold, judged from its module mark and every combination of the other marks
the expression names."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import deselects_whole_file

WARP_FILE = "import pytest\n\npytestmark = pytest.mark.warp  # needs the gpu extra\n\ndef test_x(): pass\n"
FAST = "not slow and not install and not warp and not readme"


@pytest.mark.parametrize(
    "source, expr, left_out",
    [
        (WARP_FILE, FAST, True),  # the fast subset: no warp test can be selected
        (WARP_FILE, "not warp", True),
        (WARP_FILE, "warp", False),
        (WARP_FILE, "slow", False),  # a warp test may also be slow
        (WARP_FILE, "not slow", False),
        (WARP_FILE, "", False),  # no -m: everything runs
        ("import pytest\n\ndef test_x(): pass\n", FAST, False),  # no module mark: decided per test
        ("pytestmark = [pytest.mark.warp, pytest.mark.slow]\n", "not slow", True),
        ("pytestmark = [pytest.mark.warp, pytest.mark.slow]\n", "warp and not slow", True),
        ("pytestmark = pytest.mark.adversarial\n", "adversarial or readme", False),
        ("pytestmark = pytest.mark.readme\n", "not readme and not warp", True),
        (WARP_FILE, "warp and cuda_only", False),  # a mark the expression names may be on some test
        (WARP_FILE, "cuda_only and not warp", True),
    ],
)
def test_a_file_is_left_unimported_only_where_no_test_of_it_can_be_selected(source, expr, left_out):
    assert deselects_whole_file(source, expr) is left_out


def test_the_gpu_files_carry_their_module_mark():
    """Every test file that imports MuJoCo Warp at its top is marked ``warp`` as a whole, so the fast subset
    leaves it unimported."""
    here = Path(__file__).resolve().parent
    for path in sorted(here.glob("test_*.py")):
        source = path.read_text()
        if 'importorskip("mujoco_warp")' in source.split("\ndef ")[0]:
            assert deselects_whole_file(source, FAST), path.name


def test_a_bad_expression_leaves_the_files_to_pytest():
    """A malformed ``-m`` is pytest's usage error to report; the rule then imports every file."""
    assert deselects_whole_file(WARP_FILE, "not (warp") is False
