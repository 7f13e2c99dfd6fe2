"""Options and output shared by the run commands (inject, spiral, compare)."""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

from rcmplan.analysis.result import RunResult
from rcmplan.cli import interrupts
from rcmplan.control.methods import METHODS
from rcmplan.control.phase import Phase
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.registry import ROBOTS, check_robot, is_robot_file
from rcmplan.scene.scenario import Scenario, load_scenario
from rcmplan.sim.registry import PLANTS


def add_run_options(p: argparse.ArgumentParser, scenario: str, many_methods: bool = False) -> None:
    """--scenario, --method (repeatable with many_methods), --plant, --out, --json, --no-plots."""
    p.add_argument("--scenario", default=scenario, help=f"scenario name or TOML file ({scenario})")
    if many_methods:
        listed = "{" + ",".join(METHODS) + "}"
        p.add_argument("--method", action="append", choices=METHODS, metavar="METHOD",
                       help=f"a method to run, repeatable: {listed} (all)")  # fmt: skip
    else:
        p.add_argument("--method", choices=METHODS, help="control method (default: the scenario's)")
    p.add_argument("--robot", type=robot_arg, metavar="NAME|FILE.toml",
                   help=f"{ROBOT_HELP} (default: the scenario's)")  # fmt: skip
    p.add_argument("--plant", choices=sorted(PLANTS), help="plant (default: the scenario's)")
    p.add_argument("--out", default=None, help="output folder (default: rcmplan-out/<command>)")
    written = "compare.json" if many_methods else "summary.json"
    p.add_argument("--json", action="store_true", help=f"print {written} instead of the table")
    skipped = "the chart" if many_methods else "figures and the HTML report"
    p.add_argument("--no-plots", action="store_true", help=f"skip {skipped}")


ROBOT_HELP = "robot: " + ", ".join(ROBOTS) + ", or a robot file FILE.toml (docs/robots.md)"


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
    from rcmplan.scene.scenario import scenario_names, shipped_text

    if source in scenario_names():
        return shipped_text(source)
    path = Path(source)
    return path.read_text() if path.is_file() else None


@contextlib.contextmanager
def progress(label: str, total: int | None = None) -> Iterator[Any]:
    """A progress bar over phases that appears only after about a second (tqdm, if installed)."""
    try:
        from tqdm import tqdm
    except ImportError:
        yield lambda _phase: None
        return
    tqdm.monitor_interval = 0  # no monitor thread: the figures may be drawn in forked processes
    bar = tqdm(
        total=total, desc=label, unit="phase", delay=1.0, file=sys.stderr, leave=False,
        disable=not sys.stderr.isatty(),
    )  # fmt: skip

    def tick(phase: Phase) -> None:
        bar.set_postfix_str(phase.name, refresh=False)
        bar.update(1)

    try:
        yield tick
    finally:
        bar.close()


def write_stopped(
    out: Path, args: argparse.Namespace, status: str, message: str, result: RunResult | None = None
) -> None:
    """Outputs of a run command stopped before it finished (interrupted, or a bad scenario):
    the partial log and summary.json with `status` and `message` when a result exists, else
    the command's stop file alone (`interrupts.write_stop_file`: no log of an earlier run left
    beside it). Signals are ignored meanwhile, and every file is written atomically."""
    from rcmplan.analysis.report import write_summary

    with interrupts.shielded():
        if result is not None:
            write_summary(replace(result, status=status, message=message), out)
            return
        doc = {"scenario": args.scenario, "status": status, "message": one_line(message)}
        interrupts.write_stop_file(out, args.command, doc)


def interrupted_message(exc: BaseException, where: str) -> str:
    """ "interrupted by SIGTERM <where>"."""
    return f"interrupted by {interrupts.signal_name(exc)} {where}".strip()


def print_summary(result: RunResult) -> None:
    """A per-phase table of the run's figures, then the lines report.html also carries
    (`analysis.summary_text`)."""
    from rcmplan.analysis.report_html import PHASE_HEAD, phase_rows
    from rcmplan.analysis.summary_text import summary_lines

    s = result.summary()
    print(f"scenario {s['scenario']}  procedure {s['procedure']}  method {s['method']}  "
          f"plant {s['plant']}  status {s['status']}")  # fmt: skip
    print(table(list(PHASE_HEAD), phase_rows(s)))
    print("\n".join(summary_lines(s)))


def one_line(text: str) -> str:
    """text with every run of whitespace (newlines too) as one space."""
    return " ".join(str(text).split())


def print_json(obj: Any) -> None:
    """JSON to stdout."""
    from rcmplan.analysis.report import jsonable

    print(json.dumps(jsonable(obj), indent=2))


def table(header: list[str], rows: list[list[Any]]) -> str:
    """A plain-text table with aligned columns."""
    rows = [[str(c) for c in r] for r in rows]
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    line = "  ".join("-" * w for w in widths)
    fmt = "  ".join("{:<" + str(w) + "}" for w in widths)
    return "\n".join([fmt.format(*header), line, *(fmt.format(*r) for r in rows)])


def finish(args: argparse.Namespace, out: Path, doc: Any, show: Callable[[], None],
           failure: str | None) -> int:  # fmt: skip
    """The end of a run command whose outputs are written: they are final (a late signal
    leaves them as they are), the JSON or the table and the folder on stdout, and exit 1 with
    `failure` on stderr if the run did not end ok."""
    interrupts.finished()
    if args.json:
        print_json(doc)
    else:
        show()
        print(f"outputs in {out}/")
    if failure:
        print(f"rcmplan {args.command}: {failure}", file=sys.stderr)
        return 1
    return 0
