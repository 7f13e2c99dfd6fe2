"""`rcmplan inject` and `rcmplan spiral`: plan, simulate, measure and plot a procedure."""

from __future__ import annotations

import argparse
import json
import sys

from rcmplan.cli.common import (
    add_run_options,
    print_json,
    print_summary,
    progress,
    scenario_from_args,
    scenario_text,
)
from rcmplan.exceptions import RcmplanError
from rcmplan.job import run_scenario


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `inject` and `spiral` subcommands."""
    for name, scenario, text in (
        ("inject", "default", "the injection of thesis section 3.4 (the main job)"),
        ("spiral", "spiral", "an off-axis spiral traced by the tip inside the eye (fig. 4.6)"),
    ):
        p = sub.add_parser(name, help=text, description=f"Plan, simulate and measure {text}.")
        add_run_options(p, scenario)
        p.set_defaults(run=run, out_default=f"rcmplan-out/{name}")


def run(args: argparse.Namespace) -> int:
    """Run the scenario, write the outputs, print the summary; exit 1 if the run stopped early."""
    from rcmplan.analysis.report import prepare_folder, summary_json, write_outputs

    out = prepare_folder(args.out or args.out_default)
    try:
        scenario = scenario_from_args(args)
    except RcmplanError as exc:
        status = f"{type(exc).__name__}: {exc}"
        (out / "summary.json").write_text(json.dumps({"scenario": args.scenario, "status": status}))
        raise
    with progress(args.command) as tick:
        result = run_scenario(scenario, on_phase=tick)
    try:
        write_outputs(
            result, out, figures=not args.no_plots, scenario_text=scenario_text(args.scenario)
        )
    except RcmplanError as exc:
        print(f"rcmplan {args.command}: could not write all outputs: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print_json(summary_json(result))
    else:
        print_summary(result)
        print(f"outputs in {out}/")
    if not result.ok:
        print(f"rcmplan {args.command}: run stopped early: {result.status}", file=sys.stderr)
        return 1
    return 0
