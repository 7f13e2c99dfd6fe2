"""The package's first import. When this process is the `rcmplan` command (`python -m rcmplan`
or the `rcmplan` script), SIGINT and SIGTERM are handled from here on
(`rcmplan.cli.interrupts.install`): an interrupt while the rest of rcmplan and numpy load still
leaves the command's summary.json with status "interrupted". Imported as a library, rcmplan
leaves the process's signal handlers alone.
"""

from __future__ import annotations

import os
import sys


def is_command() -> bool:
    """True when this process runs the `rcmplan` command: `python [options] -m rcmplan ...`
    (read from `sys.orig_argv`), or a program named `rcmplan` (the installed script)."""
    argv = list(getattr(sys, "orig_argv", []))
    i = 1
    while i < len(argv):
        arg = argv[i]
        if arg.startswith("-m"):
            return (arg[2:] or (argv[i + 1] if i + 1 < len(argv) else "")) == "rcmplan"
        if arg in ("-c", "-") or not arg.startswith("-"):
            break  # a command string, standard input or a script: not the module
        i += 2 if arg in ("-X", "-W") else 1  # the two options whose value may stand apart
    return bool(sys.argv) and os.path.basename(sys.argv[0]) == "rcmplan"


if is_command():
    from rcmplan._signals import signals_deferred

    with signals_deferred():  # a signal while the handler loads goes to it once installed
        from rcmplan.cli import interrupts

        interrupts.install(sys.argv[1:])
