"""`rcmplan reproduce`: the thesis's chapter 4 experiments, thesis figure versus rcmplan figure."""

from __future__ import annotations

import argparse
import json
from typing import Any

from rcmplan.cli.common import print_json


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `reproduce` subcommand."""
    p = sub.add_parser(
        "reproduce", help="rerun the thesis's experiments and compare figures",
        description="Rerun the experiments of the thesis's chapter 4 with the thesis's "
        "settings (as interpreted, stated in the output) and rcmplan's, beside the figures "
        "the thesis reports.",
    )  # fmt: skip
    p.add_argument("--out", default="rcmplan-out/reproduce", help="output folder")
    p.add_argument("--json", action="store_true", help="print the table as JSON")
    p.add_argument("--no-plots", action="store_true", help="skip figures")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Run each experiment with the thesis setting (as interpreted) and rcmplan's."""
    from rcmplan.analysis.report import jsonable, prepare_folder
    from rcmplan.cli.robot import table
    from rcmplan.scene import thesis

    out = prepare_folder(args.out)
    rows = []
    for key, experiment in thesis.EXPERIMENTS.items():
        dev, its, wall = thesis.THESIS_FIGURES[key]
        row: dict[str, Any] = {"experiment": key, "reported_rcm_deviation": dev,
                               "reported_iterations": its, "reported_time": wall}  # fmt: skip
        for setting in ("thesis", "rcmplan"):
            o = experiment(setting)
            row[f"{setting}_status"] = o.status
            row[f"{setting}_max_rcm_deviation_m"] = o.max_rcm_deviation_m
            row[f"{setting}_iterations"] = o.iterations
            row[f"{setting}_steps"] = o.steps
            row[f"{setting}_wall_time_s"] = o.wall_time_s
            if not args.no_plots and len(o.log):
                from rcmplan.analysis.plots import rcm_deviation_envelope
                from rcmplan.robot.iramis import Iramis
                from rcmplan.scene.eye import default_eye

                eye = default_eye(Iramis())
                rcm_deviation_envelope(o.log, eye, out / f"{key}-{setting}.png")
        rows.append(row)
    (out / "reproduce.json").write_text(json.dumps(jsonable(rows), indent=2))
    if args.json:
        print_json(rows)
        return 0
    body = []
    for r in rows:
        for setting in ("thesis", "rcmplan"):
            dev = r[f"{setting}_max_rcm_deviation_m"]
            body.append([
                r["experiment"], setting,
                "-" if dev is None else f"{dev * 1e6:.4g}",
                f"{r[f'{setting}_iterations']} / {r[f'{setting}_steps']}",
                f"{r[f'{setting}_wall_time_s']:.3f}",
                r["reported_rcm_deviation"] if setting == "thesis" else "",
                r["reported_iterations"] if setting == "thesis" else "",
                r["reported_time"] if setting == "thesis" else "",
            ])  # fmt: skip
    head = ["experiment", "setting", "max RCM dev [um]", "iterations / steps", "wall [s]",
            "thesis reports: RCM dev", "iterations", "time"]  # fmt: skip
    print(table(head, body))
    print("\nInterpretations (see rcmplan.scene.thesis):")
    print((thesis.__doc__ or "").split("\n\n", 1)[1].strip())
    print(f"\noutputs in {out}/")
    return 0
