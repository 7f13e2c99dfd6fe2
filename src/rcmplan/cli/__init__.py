"""The `rcmplan` command line: one module per subcommand, each with `register(subparsers)`.

`rcmplan COMMAND ...` imports and registers that command's module only (`modules_for`), so a
command starts with what it needs; help, a missing or an unknown command register them all.
"""

from __future__ import annotations

from rcmplan.cli import interrupts

# First, before any other import: the command handles SIGINT and SIGTERM from here on
# (docs/report.md, "Interrupted runs": what the interpreter's start-up leaves before it).
interrupts.install_if_command()

import argparse
import importlib
import os
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

from rcmplan.exceptions import RcmplanError, did_you_mean

COMMANDS = (
    "compare",
    "inject",
    "render",
    "reproduce",
    "robot",
    "scenario",
    "subretinal",
    "sweep",
    "teleop",
    "view",
)
# Commands that another command's module registers beside its own (`inject` and `spiral`).
MODULE_OF = {"spiral": "inject"}


class Parser(argparse.ArgumentParser):
    """argparse reading every word that starts with '-' and a digit as a value, never as an
    option (rcmplan has no option spelled so): `--target -1,0,10.5` gives the negative
    coordinates as typed, as Python 3.13's argparse does."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = re.compile(r"-\.?\d")

    def error(self, message: str) -> NoReturn:
        """Usage and the error, with the closest valid word to a misspelt choice."""
        found = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)$", message)
        if found:
            choices = re.findall(r"'([^']*)'", found.group(2))
            message += did_you_mean(found.group(1), choices)
        super().error(message)


def unrecognized(parser: argparse.ArgumentParser, words: Sequence[str]) -> NoReturn:
    """The command's usage and the words it does not know, with the closest of its options to
    the first unknown option."""
    options = [o for a in parser._actions for o in a.option_strings if o.startswith("--")]
    first = next((w.split("=", 1)[0] for w in words if w.startswith("-")), "")
    parser.error(f"unrecognized arguments: {' '.join(words)}" + did_you_mean(first, options))


def modules_for(argv: Sequence[str]) -> tuple[str, ...]:
    """The command modules (of COMMANDS) the parser of `argv` needs: the one of the command it
    names; none for `--version` alone (argparse prints it and exits before a command is
    needed); every one otherwise, so that help (`rcmplan`, `-h` before the command) and the
    "invalid choice" error of a missing or misspelt command list every command."""
    for word in argv:
        module = word if word in COMMANDS else MODULE_OF.get(word)
        if module is not None:
            return (module,)
        if not _is_version(word):
            return COMMANDS
    return () if argv else COMMANDS


def _is_version(word: str) -> bool:
    """True for `--version` or an abbreviation argparse reads as it (`--v` up)."""
    return len(word) >= 3 and "--version".startswith(word)


def build_parser(modules: Sequence[str] = COMMANDS) -> argparse.ArgumentParser:
    """The argument parser with the commands of `modules` registered (each one of COMMANDS;
    all by default)."""
    parser = Parser(
        prog="rcmplan",
        description="Plan, simulate and measure RCM-constrained needle motions (iRAM!S robot).",
    )
    from rcmplan._version import __version__

    parser.add_argument("--version", action="version", version=f"rcmplan {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in modules:
        importlib.import_module(f"rcmplan.cli.{name}").register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the process exit code.

    Errors print as one line on stderr (exit 2). A reader that closes the pipe early
    (`rcmplan inject | head`) ends the command quietly, as other command-line tools do.
    SIGINT and SIGTERM stop a command after it writes its partial outputs with status
    "interrupted" (exit 130 and 143; `rcmplan.cli.interrupts`).
    """
    words = sys.argv[1:] if argv is None else argv
    parser = build_parser(modules_for(words))
    args, extra = parser.parse_known_args(words)
    if extra:
        unrecognized(command_parsers(parser)[args.command], extra)
    return _run(args)


def command_parsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The parsers of the commands registered in `parser` (built by `build_parser`), by name."""
    (sub,) = (a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def _run(args: argparse.Namespace) -> int:
    """Run the parsed command inside `interrupts.handled()`; the handling of an interrupt
    encloses that block, so a signal at its first instruction is handled as any other."""
    try:
        with interrupts.handled():
            code: int = args.run(args)
            sys.stdout.flush()
    except KeyboardInterrupt as exc:
        unanswered = not interrupts.answered()
        with interrupts.shielded():  # a second signal cannot cut the partial outputs or cleanup
            _stopped(args, exc, unanswered)
            return interrupts.leave(interrupts.exit_code(exc))
    except RcmplanError as exc:
        print(f"rcmplan {args.command}: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # Send what is left to /dev/null so the interpreter's final flush cannot fail again.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141  # 128 + SIGPIPE, the shell's code for a closed pipe
    return code


def _stopped(args: argparse.Namespace, exc: KeyboardInterrupt, unanswered: bool) -> None:
    """Say that the command was interrupted; write its stop file when the interrupt reached
    no handling of the command's own (`unanswered`: while it started its run, or in a command
    without one), keeping the records this process wrote."""
    name = interrupts.signal_name(exc)
    out = getattr(args, "out", None)
    if unanswered and args.command in interrupts.STOP_FILES and out:
        where = "during the run" if interrupts.wrote_outputs(Path(out), args.command) else (
            "before the run")  # fmt: skip
        doc = {"status": "interrupted", "message": f"interrupted by {name} {where}"}
        try:
            interrupts.write_stop_file(Path(out), args.command, doc)
        except OSError as err:
            print(f"rcmplan {args.command}: could not write to {out}: {err}", file=sys.stderr)
    print(f"rcmplan {args.command}: interrupted by {name}", file=sys.stderr)
