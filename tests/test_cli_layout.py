"""The command line's layout (issue 37): one module per command under ``experiments/cli/``, each shared
option declared once (``cli/options.py``), and ``run``'s trial options generated from ``TrialConfig``'s
fields, their defaults and ``psychophysics.bounds.LIMITS``, without importing MuJoCo or numba."""

from __future__ import annotations

import argparse
import ast
import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import pytest

from experiments.__main__ import COMMANDS, build_parser
from experiments.cli.options import SHARED
from experiments.psychophysics.bounds import LIMITS
from experiments.psychophysics.trial_fields import TRIAL_CHOICES, TRIAL_DEFAULTS

ROOT = Path(__file__).resolve().parents[1]
EXPERIMENTS = ROOT / "experiments"
#: (file, option) declared outside cli/options.py on purpose, with the reason
NOT_SHARED = {
    # a docs-maintenance script: --data is the folder its two CSVs go to, not a localization data set
    ("experiments/oculomotor/recordings.py", "--data"),
}


def _subparser(command: str) -> argparse.ArgumentParser:
    sub = next(a for a in build_parser(command)._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[command]


def test_every_command_has_its_own_module():
    for name, (module, _) in COMMANDS.items():
        assert module == f"experiments.cli.{name}", name
        path = EXPERIMENTS / "cli" / f"{name}.py"
        assert path.is_file(), path
        tree = ast.parse(path.read_text())
        defined = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
        assert {"add_subcommand", "run"} <= defined, (name, defined)
        assert _subparser(name).get_default("func").__module__ == module, name


def test_no_product_package_builds_a_parser():
    """Parsers are built in ``experiments/cli/`` (and the top level's in ``__main__``); a recipe run as
    ``python -m experiments.agents.X`` and the docs-maintenance scripts ``oculomotor.recordings``,
    ``oculomotor.fit_diagnosis`` and ``psychophysics.timing_sweep`` keep their own ``main()``."""
    own_main = {"experiments/__main__.py", "experiments/agents/sb3_recipe.py", "experiments/agents/skrl_recipe.py",
                "experiments/oculomotor/recordings.py", "experiments/oculomotor/fit_diagnosis.py",
                "experiments/psychophysics/timing_sweep.py"}
    found = []
    for path in EXPERIMENTS.rglob("*.py"):
        rel = path.relative_to(ROOT).as_posix()
        if rel.startswith("experiments/cli/") or rel in own_main:
            continue
        text = path.read_text()
        if "add_parser(" in text or "ArgumentParser(" in text or "def add_subcommand" in text:
            found.append(rel)
    assert not found, found


def _declarations() -> list[tuple[str, int, str]]:
    """(file, line, option) of every ``add_argument("--option", ...)`` in experiments/."""
    out = []
    for path in sorted(EXPERIMENTS.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "add_argument":
                out += [(path.relative_to(ROOT).as_posix(), node.lineno, a.value) for a in node.args
                        if isinstance(a, ast.Constant) and isinstance(a.value, str) and a.value.startswith("--")]
    return out


def test_each_shared_option_is_declared_once():
    decl = _declarations()
    outside = [(f, line, o) for f, line, o in decl
               if o in SHARED and f != "experiments/cli/options.py" and (f, o) not in NOT_SHARED]
    assert not outside, outside
    here = {o for f, _, o in decl if f == "experiments/cli/options.py"}
    assert here == set(SHARED), set(SHARED) ^ here
    # each is declared once there, and more than one command has it (else it is not shared)
    assert all(sum(o == s for f, _, o in decl if f == "experiments/cli/options.py") == 1 for s in SHARED)
    users = {o: {c for c in COMMANDS for a in _subparser(c)._actions if o in a.option_strings} for o in SHARED}
    assert all(len(c) >= 2 for c in users.values()), users


def test_an_option_declared_in_two_command_modules_is_shared():
    """An option of the same name in two command modules is declared in cli/options.py (or listed here,
    where its meaning differs by command)."""
    differ = {"--out", "--model", "--episodes", "--amplitudes", "--bootstrap", "--size", "--policy",
              "--hyperparams", "--eval-episodes"}
    files: dict[str, set[str]] = {}
    for f, _, o in _declarations():
        if f.startswith("experiments/cli/") and f != "experiments/cli/options.py":
            files.setdefault(o, set()).add(f)
    twice = {o for o, fs in files.items() if len(fs) > 1} - differ
    assert not twice, {o: sorted(files[o]) for o in twice}


# ---------------------------------------------------------------------------------------------- run's options
def _config_defaults() -> dict:
    from experiments.psychophysics import TrialConfig

    c = TrialConfig()
    plain = {f.name: getattr(c, f.name) for f in dataclasses.fields(c)}
    return {**plain, **{f.name: getattr(c.timecourse, f.name) for f in dataclasses.fields(c.timecourse)}}


def test_trial_fields_are_trialconfigs_defaults():
    """``trial_fields`` (light, read by the command line) holds exactly ``TrialConfig``'s plain fields and
    defaults, and the values whose home imports MuJoCo or numba agree with that home."""
    import models
    from experiments.psychophysics import TrialConfig
    from experiments.psychophysics.decode import DEFAULT_THRESHOLD

    objects = {"timecourse", "generator", "observer", "population"}
    fields = [f.name for f in dataclasses.fields(TrialConfig) if f.name not in objects]
    assert list(TRIAL_DEFAULTS) == fields
    defaults = _config_defaults()
    assert {k: defaults[k] for k in fields} == TRIAL_DEFAULTS
    assert TRIAL_DEFAULTS["visual_latency_ms"] == models.VISUAL_LATENCY_MS
    assert TRIAL_DEFAULTS["threshold"] == DEFAULT_THRESHOLD
    assert TRIAL_CHOICES["saccade_model"] == tuple(models.SACCADE_MODELS)
    assert TRIAL_CHOICES["eye_drive"] == tuple(models.EYE_DRIVES)
    for name, choices in TRIAL_CHOICES.items():  # TrialConfig accepts each choice and refuses another
        TrialConfig(**{name: choices[-1]})
        with pytest.raises(ValueError):
            TrialConfig(**{name: "no-such-" + name})


def test_run_options_are_trialconfigs_fields_defaults_and_limits():
    from experiments.cli import run
    from experiments.cli.trialconfig import option_name

    parser = _subparser("run")
    actions = {o: a for a in parser._actions for o in a.option_strings}
    defaults = _config_defaults()
    # every field of TrialConfig is an option of run, set in another form, or left at its default on purpose
    assert set(defaults) == set(run.RUN_FIELDS) | set(run.OWN_FORM) | set(run.NOT_OPTIONS) | {"timecourse"}
    for field in run.RUN_FIELDS:
        action = actions[option_name(field)]
        assert action.dest == field and action.default == defaults[field], field
        if field in TRIAL_CHOICES:
            assert tuple(action.choices) == TRIAL_CHOICES[field], field
            continue
        lim = LIMITS[field]
        assert lim.text() in action.help, (field, action.help)
        for v in (lim.lo, lim.hi):
            if not ((v == lim.lo and lim.lo_open) or (v == lim.hi and lim.hi_open)):
                assert action.type(repr(v) if not lim.integer else str(int(v))) == v, (field, v)
        step = 1 if lim.integer else max(1e-6, 1e-6 * abs(lim.hi - lim.lo))
        for bad in (lim.lo - step, lim.hi + step, "nan"):
            with pytest.raises(argparse.ArgumentTypeError):
                action.type(str(bad))
    for option in run.OWN_FORM.values():
        assert option in actions, option
    assert actions["--markers"].default == TRIAL_DEFAULTS["markers"]
    assert actions["--disable"].default == TRIAL_DEFAULTS["disabled"]
    assert actions["--no-ruler"].default is (not TRIAL_DEFAULTS["ruler"])


def test_run_at_its_defaults_is_trialconfigs_defaults():
    from experiments.cli.run import _build
    from experiments.psychophysics import TrialConfig

    args = build_parser("run").parse_args(["run", "--out", "unused"])
    _, config, _ = _build(args)
    assert config == TrialConfig()


def test_fit_forward_model_options_have_trialconfigs_ranges():
    parser = _subparser("fit")
    actions = {o: a for a in parser._actions for o in a.option_strings}
    for field in ("image_size", "fovy_deg", "fovea_deg", "endpoint_noise"):
        a = actions["--" + field.replace("_", "-")]
        assert a.default is None and LIMITS[field].text() in a.help
        with pytest.raises(argparse.ArgumentTypeError):
            a.type(str(LIMITS[field].hi * 2 + 1))
    assert tuple(actions["--saccade-model"].choices) == TRIAL_CHOICES["saccade_model"]


def test_run_help_imports_neither_mujoco_nor_numba():
    """``run --help`` builds the trial options without importing ``trial.py`` (MuJoCo, numba, conformal)."""
    code = ("import contextlib, io, json, sys\nfrom experiments.__main__ import main\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            "    try:\n        main(['run', '--help'])\n    except SystemExit:\n        pass\n"
            "print(json.dumps(sorted(sys.modules)))\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.returncode == 0, r.stderr
    modules = set(json.loads(r.stdout.strip().splitlines()[-1]))
    heavy = {"numba", "mujoco", "torch", "rerun", "conformal", "models", "envs", "experiments.psychophysics.trial"}
    assert not heavy & modules, heavy & modules
