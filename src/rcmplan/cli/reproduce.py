"""`rcmplan reproduce`: the thesis's chapter 4 experiments, the thesis's reported figures beside
rcmplan's runs of the thesis setting and rcmplan's setting, on the same axes."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from rcmplan.cli import interrupts
from rcmplan.cli.common import add_json, add_no_plots, add_out
from rcmplan.cli.output import interrupted_message, print_json

HEAD = ["experiment", "setting", "max RCM dev. [um]", "iterations / steps", "per step",
        "wall [s]", "status"]  # fmt: skip


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `reproduce` subcommand."""
    p = sub.add_parser(
        "reproduce", help="rerun the thesis's experiments and compare figures",
        description="Rerun the experiments of the thesis's chapter 4 with the thesis's "
        "settings (as interpreted, stated in the output) and rcmplan's, beside the figures "
        "the thesis reports; docs/thesis.md explains why the thesis settings do not "
        "reproduce the thesis's behaviour. The experiments run the thesis's robot (iRAM!S) "
        "with the thesis's and rcmplan's settings, so the command takes no scenario, robot "
        "or method.",
    )  # fmt: skip
    add_out(p, "reproduce")
    add_json(p)
    add_no_plots(p)
    p.set_defaults(run=run)


def experiment_row(key: str, outcomes: dict[str, Any]) -> dict[str, Any]:
    """One JSON row: what the thesis reports (with its source) and both settings' figures."""
    from rcmplan.cli.thesis_figures import REPORTED

    rep = REPORTED[key]
    row: dict[str, Any] = {
        "experiment": key,
        "thesis_reported": {"rcm_deviation_bound_m": rep.rcm_deviation_m,
                            "rcm_deviation": rep.rcm_deviation_text,
                            "iterations": rep.iterations_text, "time": rep.time_text,
                            "source": rep.source},
    }  # fmt: skip
    for setting, o in outcomes.items():
        row[setting] = {"status": o.status, "max_rcm_deviation_m": o.max_rcm_deviation_m,
                        "iterations": o.iterations, "steps": o.steps,
                        "wall_time_s": o.wall_time_s}  # fmt: skip
    return row


def table_rows(rows: list[dict[str, Any]]) -> tuple[list[list[str]], list[list[str]]]:
    """Text rows: what the thesis reports, and rcmplan's runs of both settings."""
    from rcmplan.analysis.units import fmt
    from rcmplan.cli.output import one_line

    reported, runs = [], []
    for r in rows:
        rep = r["thesis_reported"]
        reported.append([r["experiment"], rep["rcm_deviation"], rep["iterations"], rep["time"],
                         rep["source"]])  # fmt: skip
        for setting in SETTINGS:
            o = r[setting]
            runs.append([r["experiment"], setting, fmt(o["max_rcm_deviation_m"], "um"),
                         f"{o['iterations']:,} / {o['steps']:,}",
                         fmt(o["iterations"] / max(o["steps"], 1)),
                         fmt(o["wall_time_s"], "s"), one_line(o["status"])[:40]])  # fmt: skip
    return reported, runs


SETTINGS = ("thesis", "rcmplan", "hypothesis")
REPORTED_HEAD = ["experiment", "RCM deviation", "iterations", "time", "source"]


def run(args: argparse.Namespace) -> int:
    """Run each experiment with the thesis setting (as interpreted) and rcmplan's; write
    summary.json (one row per experiment) and a figure per experiment in OUT/figures.

    Interrupted (SIGINT, SIGTERM), it writes summary.json with status "interrupted", the rows
    of the experiments that finished and their figures, then re-raises (exit 130 or 143).
    """
    from rcmplan.analysis import thesis
    from rcmplan.analysis.report import prepare_folder, write_json
    from rcmplan.cli.output import table

    out = prepare_folder(args.out)
    rows: list[dict[str, Any]] = []
    figures: dict[str, str] = {}
    try:
        with interrupts.surfaced():
            run_experiments(out, not args.no_plots, rows, figures)
            doc = summary(rows, figures, "ok", "")
            write_json(out / "summary.json", doc)
            interrupts.finished()  # inside the handling below: no instant falls between
    except KeyboardInterrupt as exc:
        with interrupts.shielded():
            where = f"during the run, after {len(rows)} of {len(thesis.EXPERIMENTS)} experiments"
            doc = summary(rows, figures, "interrupted", interrupted_message(exc, where))
            write_json(out / "summary.json", doc)
        raise
    if args.json:
        print_json(doc)
        return 0
    reported, runs = table_rows(rows)
    print("The thesis reports:")
    print(table(REPORTED_HEAD, reported))
    print("\nrcmplan (kinematic plant): the thesis setting as interpreted, rcmplan's setting, and "
          "the hypothesis\n(a reading of the V-REP setup that reproduces the thesis's figures, "
          "rcmplan.cli.thesis_hypothesis):")  # fmt: skip
    print(table(HEAD, runs))
    print("\nInterpretations (rcmplan.analysis.thesis):")
    print((thesis.__doc__ or "").split("\n\n", 1)[1].strip())
    print("\nWhy the thesis settings do not give the thesis's drift, iterations and DLS "
          "precision, measured: docs/thesis.md (python benchmarks/thesis_study.py).")  # fmt: skip
    print(f"\noutputs in {out}/")
    return 0


def run_experiments(
    out: Path, plots: bool, rows: list[dict[str, Any]], figures: dict[str, str]
) -> None:
    """Each experiment with every setting, appending its row to `rows` as it finishes, then
    its figure (out/figures/<experiment>.png) to `figures` when `plots`, drawn as a run's
    figures are (`analysis.parallel.run_jobs`: in a child process while this one waits)."""
    from functools import partial

    from rcmplan.analysis import style, thesis
    from rcmplan.analysis.parallel import run_jobs
    from rcmplan.cli import thesis_hypothesis
    from rcmplan.cli.thesis_figures import experiment_figure

    for key, experiment in thesis.EXPERIMENTS.items():
        outcomes = {setting: experiment(setting) for setting in ("thesis", "rcmplan")}
        outcomes["hypothesis"] = thesis_hypothesis.EXPERIMENTS[key]()
        rows.append(experiment_row(key, outcomes))
        if plots:
            style.plt()  # matplotlib imported once, before any fork
            path = out / "figures" / f"{key}.png"
            title = outcomes["thesis"].experiment
            run_jobs([(path, partial(experiment_figure, key, title, outcomes, path))])
            figures[key] = str(path)


def summary(
    rows: list[dict[str, Any]], figures: dict[str, str], status: str, message: str
) -> dict[str, Any]:
    """summary.json's content: the experiments' rows and figures so far, with the status."""
    return {"command": "reproduce", "status": status, "message": message, "experiments": rows,
            "figures": figures}  # fmt: skip
