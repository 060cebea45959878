"""The installed package works, not only the checkout.

* The wheel, installed non-editable into a fresh virtual environment, carries every subpackage
  and data file: every command's ``--help`` and ``run --quick`` work from another directory.
* ``import conformal`` works from a read-only install with no writable home (numba then cannot
  cache its kernels on disk: it warns and compiles them in memory).

Nothing is downloaded: the wheel is built without build isolation (this interpreter's setuptools)
and installed with ``--no-index --no-deps`` into a fresh venv that sees this environment's
site-packages through a ``.pth`` line. That venv may import only the project's declared
dependencies (``Requires-Dist`` of the wheel, and theirs): an import of any other installed
distribution (pytest, torch, ray, ...) fails there, so a dependency missing from
``pyproject.toml`` still fails this test, as it would in a real install. Where the build or the
venv cannot be made offline (no setuptools, no ensurepip) the tests skip saying why.
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
import sysconfig
import textwrap
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _commands() -> list[str]:
    from experiments.__main__ import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    return sorted(sub.choices)


def test_every_command_is_listed():
    assert set(_commands()) >= {"run", "visualize", "train", "evaluate"}


#: a hang guard, never a limit a loaded machine reaches
HANG_S = 3600

#: installed in the fresh venv's site-packages: hides every distribution of this environment that
#: the wheel does not (transitively) require, so an undeclared dependency fails as in a real install
_DECLARED_ONLY = textwrap.dedent("""
    import importlib.abc, importlib.metadata as md, re, sys

    def _closure(name):
        seen, todo = set(), [name]
        while todo:
            n = re.sub(r"[-_.]+", "-", todo.pop()).lower()
            if n in seen:
                continue
            seen.add(n)
            try:
                reqs = md.requires(n) or []
            except md.PackageNotFoundError:
                continue
            for r in reqs:
                if "extra ==" in r.replace("extra==", "extra =="):
                    continue  # an optional extra's requirement
                todo.append(re.match(r"[A-Za-z0-9_.-]+", r).group(0))
        return seen

    _allowed = _closure("conformal-head")
    _hidden = {mod for mod, dists in md.packages_distributions().items()
               if not any(re.sub(r"[-_.]+", "-", d).lower() in _allowed for d in dists)}

    class _Undeclared(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name.partition(".")[0] in _hidden:
                raise ModuleNotFoundError(f"{name} is installed but not a declared dependency of conformal-head")
            return None

    sys.meta_path.insert(0, _Undeclared())
""")


@pytest.fixture(scope="module")
def installed_venv(tmp_path_factory) -> Path:
    """A fresh venv with the project's wheel (built from this checkout) installed non-editable,
    offline: this environment's packages stand in for the dependencies pip would download."""
    if importlib.util.find_spec("setuptools") is None:
        pytest.skip("building the wheel offline needs setuptools in this environment (no build isolation)")
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"  # a clean copy: no build/ or egg-info left over from earlier builds
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, src / name)
    for pkg in ("conformal", "models", "envs", "experiments"):
        shutil.copytree(ROOT / pkg, src / pkg, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    wheels = tmp / "dist"
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", str(src), "--no-deps", "--no-index",
                            "--no-build-isolation", "-q", "-w", str(wheels)],
                           capture_output=True, text=True, timeout=HANG_S)
    assert build.returncode == 0, build.stderr[-3000:]
    (wheel,) = wheels.glob("conformal_head-*.whl")
    env_dir = tmp / "venv"
    try:
        venv.EnvBuilder(with_pip=True).create(env_dir)  # ensurepip: pip's bundled wheel, offline
    except (subprocess.CalledProcessError, OSError) as exc:
        pytest.skip(f"cannot create a venv with pip offline here (ensurepip: {exc})")
    py = env_dir / "bin" / "python"
    site = Path(subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               capture_output=True, text=True, check=True).stdout.strip())
    inst = subprocess.run([str(py), "-m", "pip", "install", "-q", "--no-index", "--no-deps", str(wheel)],
                          capture_output=True, text=True, timeout=HANG_S)
    assert inst.returncode == 0, inst.stderr[-3000:]
    # then this environment's packages, after the venv's own on sys.path, and the guard
    here = {sysconfig.get_paths()[k] for k in ("purelib", "platlib")}
    (site / "_this_env.pth").write_text("".join(p + "\n" for p in sorted(here)))
    (site / "_declared_only.py").write_text(_DECLARED_ONLY)
    (site / "zz_declared_only.pth").write_text("import _declared_only\n")
    return py


def _run_elsewhere(py: Path, cwd: Path, *args: str, timeout: float = HANG_S) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    return subprocess.run([str(py), *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


@pytest.mark.install
def test_fresh_venv_hides_undeclared_packages(installed_venv, tmp_path):
    """The guard that stands in for a real install: test-only packages cannot be imported there."""
    r = _run_elsewhere(installed_venv, tmp_path, "-c", "import pytest")
    assert r.returncode != 0 and "not a declared dependency" in r.stderr, r.stderr[-3000:]
    r = _run_elsewhere(installed_venv, tmp_path, "-c", "import numpy, mujoco, gymnasium, conformal")
    assert r.returncode == 0, r.stderr[-3000:]


@pytest.mark.install
def test_wheel_holds_every_package(installed_venv, tmp_path):
    code = ("import conformal, models, envs, experiments, experiments.psychophysics, experiments.agents, pathlib;"
            "print(pathlib.Path(experiments.__file__).parent)")
    r = _run_elsewhere(installed_venv, tmp_path, "-c", code)
    assert r.returncode == 0, r.stderr[-3000:]
    where = Path(r.stdout.strip())
    assert "site-packages" in where.parts and ROOT not in where.parents  # not the checkout


@pytest.mark.install
def test_installed_commands_help(installed_venv, tmp_path):
    r = _run_elsewhere(installed_venv, tmp_path, "-m", "experiments", "--help")
    assert r.returncode == 0, r.stderr[-3000:]
    for cmd in _commands():
        r = _run_elsewhere(installed_venv, tmp_path, "-m", "experiments", cmd, "--help")
        assert r.returncode == 0, (cmd, r.stderr[-3000:])
        assert "usage:" in r.stdout


@pytest.mark.install
def test_installed_quick_study(installed_venv, tmp_path):
    r = _run_elsewhere(installed_venv, tmp_path, "-m", "experiments", "run", "--quick", "--out", "q", "--no-progress")
    assert r.returncode == 0, r.stderr[-3000:]
    out = tmp_path / "q"
    for name in ("trials.csv", "trials.parquet", "summary.txt", "fig11.png", "study.rrd", "run.json"):
        assert (out / name).stat().st_size > 0, name


@pytest.mark.slow
def test_import_without_a_writable_cache(tmp_path):
    """A read-only install and no writable home: numba finds no cache locator. The package still
    imports (with a warning) and its compiled kernels still run, uncached."""
    pkg = tmp_path / "site"
    shutil.copytree(ROOT / "conformal", pkg / "conformal", ignore=shutil.ignore_patterns("__pycache__"))
    (pkg / "conformal" / "__pycache__").write_text("")  # not a folder: no in-tree cache (works as root too)
    env = {k: v for k, v in os.environ.items() if k not in ("XDG_CACHE_HOME", "NUMBA_CACHE_DIR")}
    env.update(HOME="/dev/null", PYTHONPATH=str(pkg))  # no writable home: no user-wide cache either
    code = ("import warnings, numpy as np\n"
            "with warnings.catch_warnings(record=True) as w:\n"
            "    warnings.simplefilter('always')\n"
            "    import conformal as C\n"
            "assert C.__file__.startswith(%r), C.__file__\n"
            "from conformal import kernels\n"
            "assert kernels.DISK_CACHE is False\n"
            "assert any('cannot cache' in str(x.message) for x in w), [str(x.message) for x in w]\n"
            "grid = C.RetinaGrid.from_picture(64, 64, dots_per_unit=4, foveal_pixels=40)\n"
            "ret = C.Retina(grid, (64, 64, 3), pixels_per_unit=4.0)\n"
            "pic = np.full((64, 64, 3), 100, np.uint8)\n"
            "s = ret.sample(pic)\n"
            "assert s.mask.any() and np.allclose(s.periphery[s.mask], 100.0) and np.allclose(s.fovea, 100.0)\n"
            "print('ok')\n") % str(pkg)
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=HANG_S)
    assert r.returncode == 0, r.stderr[-3000:]
    assert r.stdout.strip().endswith("ok")
