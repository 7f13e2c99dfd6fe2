"""Options shared by the commands: one helper per option (`add_scenario`,
`add_robot`, `add_method`, `add_plant`, `add_out`, `add_json`, `add_no_plots`), so an option
reads, checks and defaults the same way in every command that has it; the scenario and robot
they name (`scenario_from_args`, `announce_robot`). What the commands print and write at their
end: `rcmplan.cli.output`."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from rcmplan.choices import METHODS, PLANTS
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.names import ROBOT_NAMES, check_robot, is_robot_file

# Reading the command line imports nothing numerical (numba, scipy): the scenario loader, the
# robots and the plants load when a command runs.
if TYPE_CHECKING:
    from rcmplan.scene.scenario import Scenario

OUT_ROOT = "rcmplan-out"  # --out defaults to OUT_ROOT/<command>
SEED_MAX = 2**32 - 1  # the largest --seed accepted (32 bits)
THE_SCENARIOS = "the scenario's"
ROBOT_HELP = f"robot: a name ({', '.join(ROBOT_NAMES)}) or a robot file FILE.toml, docs/robots.md"


def add_run_options(
    p: argparse.ArgumentParser, command: str, scenario: str, many_methods: bool = False
) -> None:
    """--scenario, --robot, --method (repeatable with many_methods), --plant, --out, --json,
    --no-plots: the options of a command that runs a scenario."""
    add_scenario(p, scenario)
    add_robot(p)
    add_method(p, many=many_methods)
    add_plant(p)
    add_out(p, command)
    add_json(p)
    add_no_plots(p, "the chart" if many_methods else "figures and the HTML report")


def add_scenario(p: argparse._ActionsContainer, default: str | None = "default",
                 what: str = "the scenario", unset: str = "") -> None:  # fmt: skip
    """--scenario NAME|FILE.toml: a shipped scenario (`rcmplan scenario --list`) or a file;
    `unset` says what the command does without one when the default is None."""
    p.add_argument("--scenario", default=default, metavar="NAME|FILE.toml",
                   help=f"{what}: a shipped scenario (rcmplan scenario --list) or a scenario "
                   f"file ({default or unset})")  # fmt: skip


def add_robot(p: argparse._ActionsContainer, default: str | None = None,
              unset: str = THE_SCENARIOS) -> None:  # fmt: skip
    """--robot NAME|FILE.toml, checked by `robot_arg` as the command line is read."""
    p.add_argument("--robot", type=robot_arg, default=default, metavar="NAME|FILE.toml",
                   help=f"{ROBOT_HELP} ({default or unset})")  # fmt: skip


def add_method(p: argparse._ActionsContainer, many: bool = False) -> None:
    """--method, one of METHODS (many: repeatable, every method when absent)."""
    listed = "{" + ",".join(METHODS) + "}"
    if many:
        p.add_argument("--method", action="append", choices=METHODS, metavar="METHOD",
                       help=f"a method to run, repeatable: {listed} (every method)")  # fmt: skip
    else:
        p.add_argument("--method", choices=METHODS, metavar=listed,
                       help=f"control method ({THE_SCENARIOS})")  # fmt: skip


def add_plant(p: argparse._ActionsContainer, choices: tuple[str, ...] | None = None,
              default: str | None = None, unset: str = THE_SCENARIOS) -> None:  # fmt: skip
    """--plant, one of `choices` (default: every registered plant)."""
    names = tuple(sorted(PLANTS)) if choices is None else choices
    p.add_argument("--plant", choices=names, default=default, metavar="{" + ",".join(names) + "}",
                   help=f"plant the run drives ({default or unset})")  # fmt: skip


def add_out(p: argparse._ActionsContainer, command: str) -> None:
    """--out DIR, default rcmplan-out/<command>, shown in --help."""
    p.add_argument("--out", default=f"{OUT_ROOT}/{command}", metavar="DIR",
                   help="output folder (%(default)s)")  # fmt: skip


def add_json(p: argparse._ActionsContainer) -> None:
    """--json: print summary.json instead of the table."""
    p.add_argument("--json", action="store_true", help="print summary.json instead of the table")


def add_no_plots(p: argparse._ActionsContainer, what: str = "the figures") -> None:
    """--no-plots: skip `what` (figures, and a report where the command writes one)."""
    p.add_argument("--no-plots", action="store_true", help=f"skip {what}")


def robot_arg(value: str) -> str:
    """argparse type of --robot: a robot name or an existing robot file (.toml)."""
    try:
        return check_robot(value)
    except InvalidInputError as exc:
        raise argparse.ArgumentTypeError(f"invalid robot {value!r}: {exc.valid}") from exc


def announce_robot(robot: str, command: str) -> None:
    """Load a robot file now (its errors stop the command before any motion) and, when the
    file gives no home, say on stderr which home was chosen."""
    if not is_robot_file(robot):
        return
    from rcmplan.robot.robot_file import load_robot_file

    loaded = load_robot_file(robot)
    if loaded.home_searched:
        print(f"rcmplan {command}: {loaded.note()}", file=sys.stderr)


def scenario_from_args(args: argparse.Namespace, procedure: str | None = None) -> Scenario:
    """The scenario named on the command line with --method and --plant applied.

    A command that fixes its procedure (`inject`, `spiral`) runs that procedure on the
    scenario's eye, points, steps and controller; when the scenario names another procedure it
    says so on stderr, so the switch is never silent.
    """
    from rcmplan.scene.scenario import load_scenario

    sc = load_scenario(args.scenario)
    if getattr(args, "robot", None):
        sc = sc.with_robot(args.robot)
    announce_robot(sc.robot, args.command)
    if procedure is not None and sc.procedure != procedure:
        print(f"rcmplan {args.command}: scenario {sc.name!r} names procedure "
              f"{sc.procedure!r}; running the {procedure} on its eye, points, steps and controller "
              f"(`rcmplan {COMMAND_OF.get(sc.procedure, 'inject')} --scenario {args.scenario}` "
              f"runs its own procedure)", file=sys.stderr)  # fmt: skip
        sc = replace(sc, procedure=procedure)
    if args.method:
        sc = sc.with_method(args.method)
    if args.plant:
        sc = sc.with_plant(args.plant)
    return sc


COMMAND_OF = {"injection": "inject", "spiral": "spiral"}


def scenario_text(source: str) -> str | None:
    """The text of the scenario file named on the command line (shipped or a path), or None."""
    from rcmplan.scene.shipped import scenario_names, shipped_text

    if source in scenario_names():
        return shipped_text(source)
    path = Path(source)
    return path.read_text() if path.is_file() else None
