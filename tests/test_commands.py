"""``python -m experiments``: the command table, ``--help`` and usage errors without heavy imports.

``--help``, a mistyped command and a usage error must answer at once (the first hour of issue 37:
12-24 s when every command module was imported before parsing). Checked here as what a fresh
process imports, not as a time: ``--help`` and a mistyped command import no command module and
none of numba, MuJoCo, torch, Rerun, scipy or matplotlib; a usage error of ``run`` imports only
``run``'s module.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import pytest

from experiments.__main__ import COMMAND_MODULES, COMMANDS, build_parser

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("numba", "mujoco", "torch", "rerun", "scipy", "matplotlib", "conformal", "models", "envs")

_PROBE = """
import contextlib, io, json, sys
from experiments.__main__ import main
out, err = io.StringIO(), io.StringIO()
with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
    try:
        code = main(json.loads(sys.argv[1]))
    except SystemExit as e:
        code = e.code
print(json.dumps({"code": code, "out": out.getvalue(), "err": err.getvalue(), "modules": sorted(sys.modules)}))
"""


def _probe(*argv: str) -> dict:
    """Run ``python -m experiments ARGV`` in a fresh process; its exit code, output and imported modules."""
    r = subprocess.run([sys.executable, "-c", _PROBE, json.dumps(list(argv))], capture_output=True, text=True,
                       cwd=ROOT, timeout=120)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


def _heavy(modules: list[str]) -> list[str]:
    return sorted({m.split(".")[0] for m in modules if m.split(".")[0] in HEAVY})


def _command_modules(modules: list[str]) -> list[str]:
    return sorted(m for m in modules if m in COMMAND_MODULES)


def test_help_lists_every_command_and_imports_none():
    r = _probe("--help")
    assert r["code"] == 0
    for name in COMMANDS:
        assert f"    {name}" in r["out"], name
    assert _heavy(r["modules"]) == [] and _command_modules(r["modules"]) == []


def test_the_table_is_what_the_modules_register():
    """Every registered command is in the table, with the module that registers it and the same help."""
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    registered = {a.dest: a.help for a in sub._choices_actions}
    assert list(registered) == list(COMMANDS)
    assert registered == {name: help_text for name, (_, help_text) in COMMANDS.items()}
    for name, (module, _) in COMMANDS.items():
        assert sub.choices[name].get_default("func").__module__.startswith(module), name


@pytest.mark.parametrize("argv, hint", [
    (["runn"], "did you mean 'run'?"),
    (["--quik"], "a command's options go after it"),
    (["--vizualize"], "did you mean the command 'visualize'?"),
])
def test_a_mistyped_command_is_one_line_and_imports_nothing(argv, hint):
    r = _probe(*argv)
    assert r["code"] == 2 and r["out"] == ""
    error = [line for line in r["err"].splitlines() if "error:" in line]
    assert len(error) == 1 and hint in error[0], r["err"]
    assert _heavy(r["modules"]) == [] and _command_modules(r["modules"]) == []


@pytest.mark.parametrize("argv, hint", [
    (["run", "--quik"], "unrecognized arguments: --quik; did you mean --quick?"),
    (["run", "--flash-times", "-100:100:20"], "must be joined to its option with '=': --flash-times=-100:100:20"),
    (["run", "--model", "observr"], "invalid choice: 'observr' (choose from 'mechanistic', 'paper', 'population', "
                                     "'observer'); did you mean 'observer'?"),
])
def test_a_usage_error_of_a_command_names_the_fix_and_imports_only_that_command(argv, hint):
    r = _probe(*argv)
    assert r["code"] == 2 and r["out"] == ""
    assert r["err"].startswith("usage: python -m experiments run ")  # the command's usage, not the top level's
    error = [line for line in r["err"].splitlines() if "error:" in line]
    assert len(error) == 1 and error[0].startswith("python -m experiments run: error: "), r["err"]
    assert hint in error[0]
    assert _command_modules(r["modules"]) == ["experiments.cli.run"]
    assert not {"numba", "mujoco", "torch", "rerun"} & set(_heavy(r["modules"]))


@pytest.mark.slow
def test_every_command_help_imports_nothing_heavy():
    """Issue 37, "the first hour": ``COMMAND --help`` answers without numba, MuJoCo, torch, Rerun, scipy
    or matplotlib, and imports only its own command module (13 fresh processes)."""
    for name in COMMANDS:
        r = _probe(name, "--help")
        assert r["code"] == 0 and f"usage: python -m experiments {name}" in r["out"], name
        assert _heavy(r["modules"]) == [], (name, _heavy(r["modules"]))
        assert _command_modules(r["modules"]) == [f"experiments.cli.{name}"], name


def test_the_lazy_parser_parses_as_the_full_one():
    argv = ["run", "--quick", "--out", "somewhere", "--seed", "3"]
    lazy, full = build_parser("run").parse_args(argv), build_parser().parse_args(argv)

    def values(ns: argparse.Namespace) -> dict:
        return {k: v for k, v in vars(ns).items() if not isinstance(v, argparse.ArgumentParser)}

    assert values(lazy) == values(full) and values(lazy)["seed"] == 3


@pytest.mark.parametrize("command", ["run", "saccades", "baselines"])
def test_help_shows_each_default_once_and_no_doubled_percent(command):
    """``ArgumentDefaultsHelpFormatter`` appended ``(default: X)`` to help that already named its
    default (``saccades --help``); a description is not %-formatted, so ``95%%`` showed as typed."""
    sub = next(a for a in build_parser(command)._actions if isinstance(a, argparse._SubParsersAction))
    parser = sub.choices[command]
    text = parser.format_help()
    assert "%%" not in text
    formatter, stock = parser._get_formatter(), argparse.ArgumentDefaultsHelpFormatter(parser.prog)
    named = [a for a in parser._actions if a.help and "default" in a.help.lower()]  # the help names its default
    for action in named:
        assert formatter._get_help_string(action) == action.help, action.option_strings
    if parser.formatter_class is argparse.ArgumentDefaultsHelpFormatter:
        assert any(stock._get_help_string(a) != a.help for a in named)  # the stock formatter doubled these
        assert any(formatter._get_help_string(a) != a.help for a in parser._actions if a.help)  # others keep theirs


@pytest.mark.slow  # pymovements' import
def test_a_command_prints_no_opengl_info_line():
    """pymovements sets the root logger to INFO; PyOpenGL then logged
    'INFO:OpenGL.acceleratesupport:No OpenGL_accelerate module loaded' in a command's output."""
    code = ("import contextlib, io\nfrom experiments.__main__ import main\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            "    try:\n        main(['--help'])\n    except SystemExit:\n        pass\n"
            "import pymovements, OpenGL.GL\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "OpenGL" not in r.stderr, r.stderr
