"""argparse types shared by the commands: bounded numbers and output paths; and the commands' parser.

Each type raises ``argparse.ArgumentTypeError`` with what was wrong, so a bad option ends in a usage
error (exit 2) with one line naming the option, never a traceback, a NaN or a silent truncation.
:class:`HintingParser` adds to each usage error how to fix it (the closest option or choice, the
``--option=-value`` form).
"""

from __future__ import annotations

import argparse
import difflib
import math
import os
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import cast

__all__ = [
    "DefaultsHelpFormatter",
    "HintingParser",
    "int_in",
    "out_dir",
    "out_file",
    "whole_number",
    "amplitude_list",
    "bounded",
    "check_path_text",
    "guarded",
]


class DefaultsHelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """``ArgumentDefaultsHelpFormatter`` that adds ``(default: X)`` only where it says something: not
    when the help already names its default, nor for a default of ``None`` or ``False``."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if "default" in text.lower() or action.default is None or action.default is False:
            return text
        # typeshed: str | None; argparse (3.11+) returns the help text, "" when there is none
        return cast(str, super()._get_help_string(action))


class HintingParser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose usage errors say how to fix them.

    * an unknown option names the closest one (``--quik``: did you mean ``--quick``?), and is
      reported by the subcommand it was given to, with that subcommand's usage (argparse reports
      a subcommand's unknown options with the top-level usage);
    * an invalid choice names the closest choice (``runn``: did you mean ``run``?);
    * an option whose value starts with ``-`` (``--flash-times -100:100:20``, which argparse reads
      as a second option: "expected one argument") is shown in the form that works,
      ``--flash-times=-100:100:20``.

    A command's help made with ``ArgumentDefaultsHelpFormatter`` shows each default once
    (:class:`DefaultsHelpFormatter`). Subparsers made with ``add_subparsers().add_parser`` are of
    this class too.
    """

    def _get_formatter(self) -> argparse.HelpFormatter:
        if self.formatter_class is argparse.ArgumentDefaultsHelpFormatter:  # no default shown twice
            return DefaultsHelpFormatter(prog=self.prog)
        return super()._get_formatter()

    def parse_known_args(self, args=None, namespace=None):
        self._argv = list(sys.argv[1:] if args is None else args)
        return super().parse_known_args(args, namespace)

    def parse_args(self, args=None, namespace=None):
        parsed, extras = self.parse_known_args(args, namespace)
        if extras:
            self._parser_of(parsed).error(f"unrecognized arguments: {' '.join(extras)}")
        return parsed

    def _parser_of(self, parsed: argparse.Namespace) -> argparse.ArgumentParser:
        """The subcommand's parser that ``parsed`` went through (or this one)."""
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):
                sub = action.choices.get(getattr(parsed, action.dest, None) or "")
                if sub is not None:
                    return sub._parser_of(parsed) if isinstance(sub, HintingParser) else sub
        return self

    def error(self, message: str):
        super().error(message + self._hint(message))

    def _hint(self, message: str) -> str:
        m = re.match(r"argument (\S+): expected (?:one|at least one|\d+) arguments?$", message)
        if m:
            names = m[1].split("/")
            argv = getattr(self, "_argv", [])
            for i, word in enumerate(argv[:-1]):
                if word in names and argv[i + 1].startswith("-") and len(argv[i + 1]) > 1:
                    return f"; a value that starts with '-' must be joined to its option with '=': {word}={argv[i + 1]}"
            return ""
        m = re.search(r"invalid choice: (.+?) \(choose from (.*)\)$", message)
        if m:
            choices = [c.strip().strip("'") for c in m[2].split(",")]
            close = difflib.get_close_matches(m[1].strip("'"), choices, n=1, cutoff=0.6)
            return f"; did you mean {close[0]!r}?" if close else ""
        m = re.match(r"unrecognized arguments: (.*)$", message)
        if m:
            options = [o for o in self._option_string_actions if o.startswith("--")]
            commands = [c for a in self._actions if isinstance(a, argparse._SubParsersAction) for c in a.choices]
            for word in m[1].split():
                if not word.startswith("-"):
                    continue
                close = difflib.get_close_matches(word.split("=")[0], options, n=1, cutoff=0.6)
                if close:
                    return f"; did you mean {close[0]}?"
                close = difflib.get_close_matches(word.lstrip("-"), commands, n=1, cutoff=0.6)
                if close:
                    return f"; did you mean the command {close[0]!r}?"
                if commands:
                    return f"; a command's options go after it: {self.prog} COMMAND {word} (see {self.prog} COMMAND --help)"
            return ""
        return ""


def whole_number(text: str) -> int:
    """``text`` as a whole number: ``12``, ``12.0`` or ``1e3``; ``ValueError`` for ``12.5``, ``nan``,
    ``inf`` or anything that is not a number."""
    try:
        return int(text)
    except ValueError:
        f = float(text)  # raises ValueError for non-numbers
        if not (math.isfinite(f) and f.is_integer()):
            raise ValueError(f"not a whole number: {text!r}") from None
        return int(f)


def int_in(minimum: int, maximum: int) -> Callable[[str], int]:
    """A whole number (:func:`whole_number`) in [minimum, maximum]."""

    def parse(text: str) -> int:
        want = f"a whole number in [{minimum}, {maximum}]"
        try:
            v = whole_number(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {want}; got {text!r}") from None
        if not minimum <= v <= maximum:
            raise argparse.ArgumentTypeError(f"expected {want}; got {text!r}")
        return v

    parse.__name__ = "integer"
    return parse


def _writable_parent(p: Path, text: str) -> None:
    parent = p.parent if str(p.parent) else Path(".")
    anc = parent
    while not anc.exists():  # the nearest existing ancestor must be a writable folder
        anc = anc.parent
    if not anc.is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} lies under {str(anc)!r}, which is a file, not a folder")
    if not os.access(anc, os.W_OK | os.X_OK):
        raise argparse.ArgumentTypeError(f"cannot write under {str(anc)!r} (permission denied); choose another path")


def check_path_text(text: str) -> None:
    """``ArgumentTypeError`` for a path with a NUL character or names longer than the file system allows."""
    from ..folders import check_path_length

    if "\x00" in text:
        raise argparse.ArgumentTypeError(f"the path contains a NUL character: {text!r}")
    try:
        check_path_length(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def out_dir(text: str) -> Path:
    """An output folder: not empty, not an existing file, under a folder this user can write, with
    names the file system allows."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a folder path; got an empty string")
    check_path_text(text)
    p = Path(text)
    if p.exists() and not p.is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} exists and is not a folder; choose a folder path")
    if p.is_dir():
        if not os.access(p, os.W_OK | os.X_OK):
            raise argparse.ArgumentTypeError(f"cannot write into {text!r} (permission denied); choose another folder")
        return p
    _writable_parent(p, text)
    return p


def out_file(*suffixes: str) -> Callable[[str], Path]:
    """An output file with one of ``suffixes`` (e.g. ``.csv``): not a folder, under a folder this
    user can write, with names the file system allows."""

    def parse(text: str) -> Path:
        if not text.strip():
            raise argparse.ArgumentTypeError("expected a file path; got an empty string")
        check_path_text(text)
        p = Path(text)
        if p.suffix.lower() not in suffixes:
            raise argparse.ArgumentTypeError(f"expected a file name ending in {' or '.join(suffixes)}; got {text!r}")
        if p.is_dir():
            raise argparse.ArgumentTypeError(
                f"{text!r} is a folder; give a file name such as {p / ('data' + suffixes[0])}"
            )
        if p.exists() and not os.access(p, os.W_OK):
            raise argparse.ArgumentTypeError(f"cannot overwrite {text!r} (permission denied); choose another path")
        _writable_parent(p, text)
        return p

    parse.__name__ = "file"
    return parse


def amplitude_list(text: str) -> tuple[float, ...]:
    """Comma-separated saccade amplitudes (deg), each a finite number within the design's bounds
    (``psychophysics.bounds.LIMITS['amplitudes_deg']``), none repeated."""
    from ..psychophysics.bounds import LIMITS

    lim = LIMITS["amplitudes_deg"]
    try:
        vals = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers in {lim.text()}; got {text!r}") from None
    if not vals:
        raise argparse.ArgumentTypeError(f"expected at least one number in {lim.text()}; got {text!r}")
    bad = [v for v in vals if not lim.contains(v)]
    if bad:
        raise argparse.ArgumentTypeError(f"each amplitude must be in {lim.text()}; got {bad[0]!r} in {text!r}")
    dup = sorted({v for v in vals if vals.count(v) > 1})
    if dup:
        raise argparse.ArgumentTypeError(
            f"amplitude {dup[0]:g} is listed twice in {text!r}; list each once (use --repetitions for more trials)"
        )
    return vals


def generator_file(text: str):
    """``--generator FILE``: a ``models.BurstGenerator`` read from a JSON file (``BurstGenerator.from_file``,
    e.g. the ``generator.json`` of ``python -m experiments saccades --recording``); a bad file is a usage error."""
    import models

    check_path_text(text)
    try:
        return models.BurstGenerator.from_file(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


GENERATOR_HELP = (
    "burst-generator parameters from a JSON file (the generator.json that `saccades --recording` "
    "fits to a person's eye-tracker recording); default: the generator's defaults"
)


def bounded(name: str, what: str = "") -> Callable[[str], float | int]:
    """An argparse type for the parameter ``name`` of ``psychophysics.bounds.LIMITS``: a usage error
    (exit 2, one line naming the option) for anything but a finite number within the bounds (a
    whole number where the limit says so); ``what`` is appended to the message."""
    from ..psychophysics.bounds import LIMITS

    lim = LIMITS[name]

    def parse(text: str):
        kind = "a whole number" if lim.integer else "a number"
        try:
            v = whole_number(text) if lim.integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {kind} in {lim.text()}; got {text!r}") from None
        if not lim.contains(v):
            raise argparse.ArgumentTypeError(f"must be {kind} in {lim.text()}{what}; got {text!r}")
        return v

    parse.__name__ = name
    return parse


def guarded(
    prog: str,
    work: Callable[[], int],
    *,
    resume_hint: str,
    errors: dict | None = None,
    usage: tuple = (),
    parser: argparse.ArgumentParser | None = None,
) -> int:
    """Run a command's ``work()`` as every command that writes results does: SIGINT/SIGTERM end it
    with one line (``resume_hint``) and exit 128 + signal; exceptions of ``usage`` are usage errors
    of ``--out`` (exit 2); those of ``errors`` (type -> exit status) and ``OSError`` (exit 1) print
    one line ``PROG: error: ...``. Anything else propagates (a bug, with its traceback)."""
    import signal
    import sys

    from ..folders import Interrupted, interruptible, os_error_text

    try:
        with interruptible():
            return work()
    except KeyboardInterrupt as e:
        signum = e.signum if isinstance(e, Interrupted) else signal.SIGINT
        print(f"{prog}: interrupted ({signal.Signals(signum).name}); {resume_hint}", file=sys.stderr)
        return 128 + int(signum)
    except usage as e:
        assert parser is not None, "usage errors need the parser"
        parser.error(f"argument --out: {e}")
    except tuple(errors or {}) as e:
        assert errors is not None, "only the kinds of a given errors mapping are caught here"
        print(f"{prog}: error: {e}", file=sys.stderr)
        return next(code for kind, code in errors.items() if isinstance(e, kind))
    except OSError as e:
        print(f"{prog}: error: {os_error_text(e)}", file=sys.stderr)
        return 1
