"""What `rcmplan sweep` writes and prints: summary.json, targets.csv, the figures, the tables,
and the summary of an interrupted sweep."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rcmplan.cli import interrupts
from rcmplan.exceptions import RcmplanError

if TYPE_CHECKING:
    from rcmplan.sweep.checkpoint import Checkpoint
    from rcmplan.sweep.gains import GainSearchResult
    from rcmplan.sweep.runner import SweepResult


def write_outputs(
    args: argparse.Namespace, out: Path, result: SweepResult, gains: GainSearchResult | None,
    resumed: dict[str, Any],
) -> dict[str, Any]:  # fmt: skip
    """targets.csv, the figures, then summary.json naming them under `figures` ({} with
    --no-plots) and the resume record under `resumed`; returns the summary."""
    from rcmplan.analysis.report import write_json
    from rcmplan.sweep import report

    s = {"command": "sweep", "status": "ok", "message": "", **report.summary(result),
         "resumed": resumed}  # fmt: skip
    if gains is not None:
        s["gain_search"] = report.gain_summary(gains)
    report.write_targets_csv(result, out / "targets.csv")
    figs: dict[str, Path] = {}
    if not args.no_plots:
        from rcmplan.sweep import maps

        figs = maps.sweep_maps(result, out / "figures")
        if gains is not None:
            figs["gains"] = maps.gain_tradeoff(gains, out / "figures" / "gains.png")
    s["figures"] = {k: str(v) for k, v in figs.items()}
    write_json(out / "summary.json", s)
    return s


def print_tables(s: dict[str, Any], gains: GainSearchResult | None) -> None:
    """The summary table and, after a gain search, the candidates table."""
    from rcmplan.cli.output import table
    from rcmplan.sweep import report

    print(table(["figure", "value", "unit"], report.summary_rows(s)))
    if gains is not None:
        print(f"\ngain search ({gains.mode}): {s['gain_search']['objective']} "
              f"({1e6 * gains.objective.rcm_bound_m:g} um); {gains.message}")  # fmt: skip
        print(table(report.GAIN_HEADER, report.gain_rows(gains)))
        if gains.best is None:
            print("no candidate met the constraints")


def write_interrupted(out: Path, checkpoint: Checkpoint, exc: BaseException) -> None:
    """summary.json of an interrupted sweep: status, why, and the results kept for --resume."""
    from rcmplan._atomic import write_text

    with interrupts.shielded():
        try:
            kept = len(checkpoint.load())
        except RcmplanError:
            kept = 0
        name = interrupts.signal_name(exc)
        message = (f"interrupted by {name}; {kept} finished results are kept in "
                   f"{checkpoint.path}; rerun with --resume to continue")  # fmt: skip
        doc = {"command": "sweep", "status": "interrupted", "message": message,
               "checkpoint": str(checkpoint.path), "results_kept": kept}  # fmt: skip
        write_text(out / "summary.json", json.dumps(doc, indent=2))
        print(f"rcmplan sweep: {message}", file=sys.stderr)
