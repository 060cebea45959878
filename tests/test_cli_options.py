"""Each option several commands share is declared once, with one range (issue 37): every command's
``--seed``, ``--image-size`` and ``--workers`` accept exactly ``psychophysics.bounds.LIMITS``' range,
and every ``--task`` chooses among the env's tasks."""

from __future__ import annotations

import argparse

import pytest

from experiments.__main__ import COMMANDS, build_parser
from experiments.cli.options import ENV_TASKS, TASKS
from experiments.psychophysics.bounds import LIMITS

SHARED = {"--seed": "seed", "--image-size": "image_size", "--workers": "workers"}


def _options() -> list[tuple[str, str, argparse.Action]]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return [(name, o, a) for name, p in sub.choices.items() for a in p._actions for o in a.option_strings]


def test_every_shared_number_option_has_the_one_range():
    seen = set()
    for command, option, action in _options():
        if option not in SHARED:
            continue
        lim = LIMITS[SHARED[option]]
        lo, hi = int(lim.lo), int(lim.hi)
        assert action.type(str(lo)) == lo and action.type(str(hi)) == hi, (command, option)
        for bad in (str(lo - 1), str(hi + 1)):
            with pytest.raises(argparse.ArgumentTypeError):
                action.type(bad)
        seen.add((command, option))
    # the commands that have these options (a command that drops one, or a new one, shows here)
    assert {c for c, o in seen if o == "--seed"} >= {"run", "train", "evaluate", "simulate", "visualize"}
    assert {c for c, o in seen if o == "--image-size"} >= {"run", "phenomena", "recovery", "train", "evaluate",
                                                          "baselines", "visualize", "fit", "compare"}
    assert {c for c, o in seen if o == "--workers"} >= {"run", "phenomena", "recovery", "fit", "compare",
                                                       "baselines"}


def test_every_task_option_chooses_among_the_env_tasks():
    from envs.tasks import TASKS as ENV

    assert set(ENV_TASKS) == set(ENV) and set(TASKS) < set(ENV)
    tasks = {command: tuple(a.choices) for command, option, a in _options() if option == "--task"}
    assert tasks and all(set(c) <= set(ENV) for c in tasks.values()), tasks
    assert tasks["visualize"] == ENV_TASKS and all(tasks[c] == TASKS for c in ("train", "evaluate", "baselines"))
    assert set(tasks) <= set(COMMANDS)
