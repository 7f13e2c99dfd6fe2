"""The `rcmplan` command line: one module per subcommand, each with `register(subparsers)`."""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence

from rcmplan.cli import interrupts
from rcmplan.exceptions import RcmplanError

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


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="rcmplan",
        description="Plan, simulate and measure RCM-constrained needle motions (iRAM!S robot).",
    )
    from rcmplan._version import __version__

    parser.add_argument("--version", action="version", version=f"rcmplan {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"rcmplan.cli.{name}").register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the process exit code.

    Errors print as one line on stderr (exit 2). A reader that closes the pipe early
    (`rcmplan inject | head`) ends the command quietly, as other command-line tools do.
    SIGINT and SIGTERM stop a command after it writes its partial outputs with status
    "interrupted" (exit 130 and 143).
    """
    with interrupts.handled():
        return _main(argv)


def _main(argv: Sequence[str] | None) -> int:
    args = build_parser().parse_args(argv)
    try:
        code: int = args.run(args)
        sys.stdout.flush()
    except KeyboardInterrupt as exc:
        with interrupts.shielded():
            name = interrupts.signal_name(exc)
            print(f"rcmplan {args.command}: interrupted by {name}", file=sys.stderr)
        return interrupts.exit_code(exc)
    except RcmplanError as exc:
        print(f"rcmplan {args.command}: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # Send what is left to /dev/null so the interpreter's final flush cannot fail again.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141  # 128 + SIGPIPE, the shell's code for a closed pipe
    return code
