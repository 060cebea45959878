"""``models.eye_kinematics`` needs no MuJoCo (issue 37, item 2): pure-numpy code imports it, and
``models`` itself, with MuJoCo unimportable.

A subprocess blocks ``mujoco`` from import (a meta-path finder that refuses it), imports the
subpackage and uses it; ground truth for the numbers: a target straight ahead of an eye is fixated
at zero Fick angles, and Listing's torsion of a purely horizontal or vertical gaze is zero. The same
block makes ``models.Head`` fail, so the test can fail.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

BLOCK = textwrap.dedent("""
    import importlib.abc, sys

    class NoMujoco(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name == "mujoco" or name.startswith(("mujoco.", "mujoco_warp")):
                raise ImportError(f"{name} is blocked in this test")
            return None

    sys.meta_path.insert(0, NoMujoco())
""")


def _run(code: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-c", BLOCK + textwrap.dedent(code)], env=env, capture_output=True,
                          text=True, timeout=300)


def test_eye_kinematics_imports_and_works_without_mujoco():
    res = _run("""
        import numpy as np
        import models
        from models.eye_kinematics import MainSequence, fixation_angles, listing_torsion

        centres = np.array([[0.0, 0.03, 0.0], [0.0, -0.03, 0.0]])
        ang = fixation_angles(np.array([1.0, 0.03, 0.0]), centres)  # straight ahead of the left eye
        assert np.allclose(ang[0], 0.0), ang
        assert np.allclose(listing_torsion([0.3, 0.0], [0.0, -0.2]), 0.0)
        assert MainSequence().duration_ms(10.0) > 0
        assert models.MainSequence is MainSequence  # the public name, from its home
        assert "mujoco" not in sys.modules
        print("ok")
    """)
    assert res.returncode == 0 and res.stdout.split() == ["ok"], res.stderr[-2000:]


def test_the_block_holds_the_head_back():
    """The blocked import is real: the MuJoCo head cannot load under it (else the test above proves nothing)."""
    res = _run("import models\nmodels.Head\n")
    assert res.returncode != 0 and "mujoco is blocked" in res.stderr, res.stderr[-2000:]


def test_every_public_name_of_models_has_one_home_and_loads():
    """``models`` loads its names on first use: each name of ``__all__`` has a home module, and nothing else does."""
    import models

    assert set(models._HOMES) == set(models.__all__)
    for name in models.__all__:
        assert getattr(models, name) is getattr(__import__(f"models.{models._HOMES[name]}", fromlist=[name]), name)
    assert set(models.__all__) <= set(dir(models))
