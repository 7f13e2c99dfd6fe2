"""`rcmplan inject` and `rcmplan spiral`: plan, simulate, measure and plot a procedure."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace

from rcmplan.cli import interrupts
from rcmplan.cli.common import add_run_options, scenario_from_args, scenario_text
from rcmplan.cli.output import (
    finish,
    interrupted_message,
    print_summary,
    progress,
    write_stopped,
)
from rcmplan.exceptions import RcmplanError
from rcmplan.job import run_scenario
from rcmplan.scene.scenario import Scenario

COMMANDS = (
    ("inject", "default", "injection", "the injection of thesis section 3.4 (the main job)"),
    ("spiral", "spiral", "spiral", "an off-axis spiral traced by the tip in the eye (fig. 4.6)"),
)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `inject` and `spiral` subcommands."""
    for name, scenario, procedure, text in COMMANDS:
        p = sub.add_parser(
            name, help=text, description=f"Plan, simulate and measure {text}. A scenario that "
            f"describes another procedure lends its eye, points, steps and controller.",
        )  # fmt: skip
        add_run_options(p, name, scenario)
        if name == "inject":
            add_tip_options(p)
        p.set_defaults(run=run, procedure=procedure)


def add_tip_options(p: argparse.ArgumentParser) -> None:
    """--target X,Y,Z (repeatable) and --path FILE.csv, in mm in the eye frame."""
    frame = ("eye frame: origin at the eye centre, z along the insertion axis from the trocar "
             "through the centre, x horizontal (z x z_base), y = z x x")  # fmt: skip
    p.add_argument("--target", action="append", metavar="X,Y,Z",
                   help=f"a tip target in mm, visited from p3 (up to 4; {frame})")  # fmt: skip
    p.add_argument("--path", metavar="FILE.csv",
                   help=f"tip points in mm, rows x,y,z, followed from p3 ({frame})")  # fmt: skip


def scenario_for(args: argparse.Namespace) -> Scenario:
    """The scenario of the command line, with --target or --path applied."""
    from rcmplan.cli import tip_input

    targets = getattr(args, "target", None)
    path = getattr(args, "path", None)
    if targets and path:
        raise RcmplanError("give --target or --path, not both")
    sc = scenario_from_args(args, None if (targets or path) else args.procedure)
    if targets:
        return tip_input.with_targets(sc, [tip_input.parse_point(t) for t in targets])
    if path:
        return tip_input.with_path(sc, tip_input.read_path_csv(path))
    return sc


def run(args: argparse.Namespace) -> int:
    """Run the scenario, write the outputs, print the summary; exit 1 if the run stopped early
    or broke a bound it states (status "limit_violated"), 2 if its plan was refused before any
    motion.

    Interrupted (SIGINT, SIGTERM) at any point, it writes what it has with status
    "interrupted" and re-raises the interrupt (the exit code is the CLI's, 130 or 143).
    """
    from rcmplan.analysis.report import prepare_folder, summary_json, write_outputs

    out = prepare_folder(args.out)
    result = None
    try:
        with interrupts.surfaced():
            scenario = scenario_for(args)
            with progress(args.command) as tick:
                result = replace(run_scenario(scenario, on_phase=tick), command=args.command)
            write_outputs(
                result, out, figures=not args.no_plots, scenario_text=scenario_text(args.scenario)
            )
            interrupts.finished()  # inside the handling below: no instant falls between
    except RcmplanError as exc:
        if result is None:
            message = f"{type(exc).__name__}: {exc}"
            write_stopped(out, args, exc.status, message)
            raise
        print(f"rcmplan {args.command}: could not write all outputs: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        if result is None:
            result = getattr(exc, "result", None)
            where = "during the run" if result is not None else "before the run"
        else:
            where = f"while writing the outputs (the run ended with status {result.status!r})"
        write_stopped(out, args, "interrupted", interrupted_message(exc, where), result)
        raise
    refused = not result.finished and len(result.log) == 0  # the plan's checks, before motion
    failure = None
    if result.status == "limit_violated":
        failure = f"limit_violated: {result.message}"
    elif not result.ok:
        failure = f"{'refused before motion' if refused else 'run stopped early'}: {result.message}"
    return finish(args, out, summary_json(result), lambda: print_summary(result), failure,
                  2 if refused else 1)  # fmt: skip
