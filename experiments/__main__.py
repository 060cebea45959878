"""``python -m experiments COMMAND``: the project's commands.

``COMMANDS`` names each command, the module that defines it (``experiments.cli.<command>``) and its
one-line help. Only the chosen command's module is imported (it builds its subparser with
``add_subcommand(subparsers)``, setting ``func`` to the function that runs it); the others are
listed by name and help. So ``--help``, a mistyped command and a usage error answer without importing
numba, MuJoCo, torch or Rerun. ``build_parser()`` builds every command's subparser (for tests and
documentation).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys

from .cli import HintingParser
from .cli.commands import HELP, module_of

#: command -> (module that defines it, one-line help), in the order ``--help`` lists them.
COMMANDS: dict[str, tuple[str, str]] = {name: (module_of(name), text) for name, text in HELP.items()}

#: command modules, in the order shown by --help
COMMAND_MODULES = tuple(module for module, _ in COMMANDS.values())


def _register(module_name: str, subparsers) -> None:
    importlib.import_module(module_name).add_subcommand(subparsers)


def build_parser(command: str | None = None, *, every: bool | None = None) -> argparse.ArgumentParser:
    """The command-line parser. ``command``: only its module is imported and builds its subparser(s);
    the other commands are listed by name and help (they take no arguments in this parser). Without
    ``command`` (or with ``every=True``) every command module is imported."""
    every = command is None if every is None else every
    parser = HintingParser(
        prog="python -m experiments",
        description="Conformal-camera binocular head: psychophysics, visualization and RL commands.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    chosen = COMMANDS.get(command or "", ("", ""))[0]
    for name, (module_name, help_text) in COMMANDS.items():
        if every or module_name == chosen:
            _register(module_name, sub)
        else:
            sub.add_parser(name, help=help_text, add_help=False)
    return parser


def chosen_command(argv: list[str]) -> str | None:
    """The command named in ``argv``: its first word that is not an option (the top level takes
    no option with a value)."""
    return next((a for a in argv if not a.startswith("-")), None)


def main(argv: list[str] | None = None) -> int:
    # PyOpenGL logs at INFO that its optional accelerator is absent; pymovements (eye-tracker
    # files) sets the root logger to INFO, which printed that line in the middle of a command's output
    logging.getLogger("OpenGL").setLevel(logging.WARNING)
    argv = sys.argv[1:] if argv is None else list(argv)
    command = chosen_command(argv)
    parser = build_parser(command, every=False)
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    return int(args.func(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
