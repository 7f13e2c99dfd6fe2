"""`rcmplan compare`: the same procedure with every method, one table and one chart."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from rcmplan.cli.common import add_run_options, print_json, scenario_from_args
from rcmplan.control.methods import METHODS
from rcmplan.exceptions import MissingExtraError
from rcmplan.job import run_scenario

COLUMNS = (
    "method",
    "status",
    "max_rcm_deviation_m",
    "max_tip_error_m",
    "iterations",
    "wall_time_s",
)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `compare` subcommand."""
    p = sub.add_parser("compare", help="run one procedure with every method and compare them")
    add_run_options(p, "default")
    p.add_argument("--methods", nargs="+", choices=METHODS, default=list(METHODS))
    p.set_defaults(run=run, out_default="rcmplan-out/compare")


def compare_rows(args: argparse.Namespace) -> list[dict[str, Any]]:
    """Run the scenario once per method; a method whose extra is missing is reported, not run."""
    base = scenario_from_args(args)
    rows = []
    for method in args.methods:
        try:
            result = run_scenario(base.with_method(method))
        except MissingExtraError as exc:
            rows.append({"method": method, "status": str(exc), "max_rcm_deviation_m": None,
                         "max_tip_error_m": None, "iterations": 0, "wall_time_s": 0.0})  # fmt: skip
            continue
        s = result.summary()
        rows.append({k: s[k] for k in COLUMNS})
    return rows


def run(args: argparse.Namespace) -> int:
    """Print the comparison table; write compare.json and the chart."""
    from rcmplan.analysis.report import jsonable, prepare_folder
    from rcmplan.cli.robot import table

    out = prepare_folder(args.out or args.out_default)
    rows = compare_rows(args)
    (out / "compare.json").write_text(json.dumps(jsonable(rows), indent=2))
    if not args.no_plots:
        from rcmplan.analysis.plots_compare import method_comparison

        method_comparison(rows, out / "compare.png")
    if args.json:
        print_json(rows)
    else:
        body = [
            [r["method"], _um(r["max_rcm_deviation_m"]), _um(r["max_tip_error_m"]),
             str(r["iterations"]), f"{1e3 * r['wall_time_s']:.1f}", r["status"][:60]]
            for r in rows
        ]  # fmt: skip
        head = [
            "method",
            "max RCM dev [um]",
            "max tip error [um]",
            "iterations",
            "wall [ms]",
            "status",
        ]
        print(table(head, body))
        print(f"outputs in {out}/")
    failed = [r["method"] for r in rows if r["status"] != "ok"]
    if failed:
        print(f"rcmplan compare: methods that did not finish: {failed}", file=sys.stderr)
        return 1
    return 0


def _um(v: float | None) -> str:
    return "-" if v is None else f"{v * 1e6:.4g}"
