"""`rcmplan compare`: the same procedure with every method, one table and one chart.

Every method runs once untimed before its measured run, so no method pays for loading or
compiling code that a later method then gets for free; each row says which code moved the
robot (`execution_path`).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

from rcmplan.analysis.result import FINISHED
from rcmplan.cli import interrupts
from rcmplan.cli.common import add_run_options, scenario_from_args
from rcmplan.cli.output import one_line, print_json
from rcmplan.control.methods import METHODS
from rcmplan.exceptions import MissingExtraError
from rcmplan.job import run_scenario
from rcmplan.robot.registry import summary_fields
from rcmplan.scene.scenario import Scenario

COLUMNS = ("method", "status", "message", "max_rcm_deviation_m", "max_tip_error_m", "iterations",
           "wall_time_s")  # fmt: skip
HEAD = ["method", "max RCM dev. [um]", "max tip error [um]", "iterations", "wall [ms]",
        "wall per iteration [us]", "path", "status"]  # fmt: skip


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `compare` subcommand."""
    text = "run one procedure with every method and compare them"
    p = sub.add_parser(
        "compare", help=text,
        description="Run the scenario's procedure once per method (--method, repeatable; all by "
        "default) on one execution path, each after an untimed warm-up run; print and write "
        "max RCM deviation, tip error, iterations and wall time (total and per iteration).",
    )  # fmt: skip
    add_run_options(p, "compare", "default", many_methods=True)
    p.set_defaults(run=run)


def measure(scenario: Scenario, out: Path | None = None) -> dict[str, Any]:
    """One row: a warm-up run, then the measured run of the scenario's method; with `out`, the
    measured run's log and summary.json go to out/<method>/ (`rcmplan view` reads them)."""
    from rcmplan.analysis.report import prepare_folder, write_summary

    run_scenario(scenario)
    result = run_scenario(scenario)
    if out is not None:
        write_summary(replace(result, command="compare"), prepare_folder(out / scenario.method))
    s = result.summary()
    row = {k: s[k] for k in COLUMNS}
    # What moved the robot, as the run itself recorded it, per phase.
    row["execution_path"] = s["execution_path"]
    row["compiled_phases"] = s["compiled_phases"]
    row["phase_count"] = len(s["phases"])
    its = s["iterations"]
    row["wall_time_per_iteration_s"] = s["wall_time_s"] / its if its else None
    return row


def compare_rows(
    args: argparse.Namespace, rows: list[dict[str, Any]], out: Path | None = None
) -> tuple[str, dict[str, str]]:
    """Run the scenario once per method, appending a row to `rows` as each method finishes
    (its run written to out/<method>/ when `out` is given); a method whose extra is missing is
    reported, not run. Returns how the execution path was chosen and the robot's summary
    fields (`summary_fields`)."""
    base = scenario_from_args(argparse.Namespace(**{**vars(args), "method": None}))
    for method in args.method or METHODS:
        try:
            rows.append(measure(base.with_method(method), out))
        except MissingExtraError as exc:
            rows.append({"method": method, "status": exc.status,
                         "message": f"MissingExtraError: {exc}",
                         "max_rcm_deviation_m": None, "max_tip_error_m": None,
                         "iterations": 0, "wall_time_s": None,
                         "wall_time_per_iteration_s": None,
                         "execution_path": None, "compiled_phases": [],
                         "phase_count": 0})  # fmt: skip
    return "compiled where a method has a kernel", summary_fields(base.robot)


def print_table(rows: list[dict[str, Any]], path: str) -> None:
    """The comparison as a text table."""
    from rcmplan.analysis.units import fmt
    from rcmplan.cli.output import table

    body = [
        [r["method"], fmt(r["max_rcm_deviation_m"], "um"), fmt(r["max_tip_error_m"], "um"),
         f"{r['iterations']:,}", fmt(r["wall_time_s"], "ms"),
         fmt(r["wall_time_per_iteration_s"], "us"), path_cell(r),
         status_cell(r)]
        for r in rows
    ]  # fmt: skip
    print(table(HEAD, body))
    print(f"execution path: {path}; wall times from the second of "
          "two runs in this process")  # fmt: skip


def status_cell(row: dict[str, Any]) -> str:
    """The table's status column: "ok", the error that stopped the run, or "limit_violated"
    and the bounds the measured motion broke; at most 100 characters."""
    text = row["message"] or row["status"]
    if row["status"] == "limit_violated":
        text = f"limit_violated: {text}"
    return one_line(text)[:100]


def path_cell(row: dict[str, Any]) -> str:
    """The table's path column: compiled, reference, or how many phases ran compiled."""
    path = row.get("execution_path")
    if path == "mixed":
        return f"{len(row['compiled_phases'])}/{row['phase_count']} compiled"
    return str(path or "-")


def run(args: argparse.Namespace) -> int:
    """Print the comparison table; write summary.json (one row per method), the chart
    (figures/compare.png), and each method's run (log and summary.json) in a folder named
    after the method.

    Interrupted (SIGINT, SIGTERM), it writes summary.json with status "interrupted" and the
    rows of the methods that finished, then re-raises (exit 130 or 143).
    """
    from rcmplan.analysis.report import prepare_folder, write_json

    out = prepare_folder(args.out)
    rows: list[dict[str, Any]] = []
    try:
        with interrupts.surfaced():
            path, robot = compare_rows(args, rows, out)
            doc: dict[str, Any] = {"command": "compare", "status": "ok", "message": "",
                                   **robot, "execution_path": path, "methods": rows}  # fmt: skip
            write_json(out / "summary.json", doc)
            if not args.no_plots:
                from rcmplan.analysis.plots_compare import method_comparison

                method_comparison(rows, out / "figures" / "compare.png")
            interrupts.finished()  # inside the handling below: no instant falls between
    except KeyboardInterrupt as exc:
        with interrupts.shielded():
            message = f"interrupted by {interrupts.signal_name(exc)} after {len(rows)} methods"
            write_json(out / "summary.json", {"command": "compare", "status": "interrupted",
                                              "message": message, "methods": rows})  # fmt: skip
        raise
    if args.json:
        print_json(doc)
    else:
        print_table(rows, path)
        print(f"outputs in {out}/")
    failed = [r["method"] for r in rows if r["status"] not in FINISHED]
    broke = [r["method"] for r in rows if r["status"] == "limit_violated"]
    if failed:
        print(f"rcmplan compare: methods that did not finish: {', '.join(failed)}",
              file=sys.stderr)  # fmt: skip
    if broke:
        print(f"rcmplan compare: methods whose measured motion broke a bound they state: "
              f"{', '.join(broke)} (each row's message)", file=sys.stderr)  # fmt: skip
    return 1 if failed or broke else 0
