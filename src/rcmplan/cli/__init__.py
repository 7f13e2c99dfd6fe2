"""The `rcmplan` command line: one module per subcommand, each with `register(subparsers)`."""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from rcmplan.exceptions import RcmplanError

COMMANDS = ("compare", "inject", "render", "reproduce", "robot", "sweep")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="rcmplan",
        description="Plan, simulate and measure RCM-constrained needle motions (iRAM!S robot).",
    )
    from rcmplan import __version__

    parser.add_argument("--version", action="version", version=f"rcmplan {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"rcmplan.cli.{name}").register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the process exit code."""
    args = build_parser().parse_args(argv)
    try:
        code: int = args.run(args)
    except RcmplanError as exc:
        print(f"rcmplan {args.command}: error: {exc}", file=sys.stderr)
        return 2
    return code
