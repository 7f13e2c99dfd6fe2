"""Options and output shared by the run commands (inject, spiral, compare)."""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from rcmplan.control.loop import Phase
from rcmplan.control.methods import METHODS
from rcmplan.job import RunResult
from rcmplan.scene.scenario import Scenario, load_scenario
from rcmplan.sim.registry import PLANTS


def add_run_options(p: argparse.ArgumentParser, scenario: str) -> None:
    """--scenario, --method, --plant, --out, --json, --no-plots."""
    p.add_argument("--scenario", default=scenario, help=f"scenario name or TOML file ({scenario})")
    p.add_argument("--method", choices=METHODS, help="control method (default: the scenario's)")
    p.add_argument("--plant", choices=sorted(PLANTS), help="plant (default: the scenario's)")
    p.add_argument("--out", default=None, help="output folder (default: rcmplan-out/<command>)")
    p.add_argument("--json", action="store_true", help="print summary.json instead of the table")
    p.add_argument("--no-plots", action="store_true", help="skip figures and the HTML report")


def scenario_from_args(args: argparse.Namespace) -> Scenario:
    """The scenario named on the command line with --method and --plant applied."""
    sc = load_scenario(args.scenario)
    if args.method:
        sc = sc.with_method(args.method)
    if args.plant:
        sc = sc.with_plant(args.plant)
    return sc


def scenario_text(source: str) -> str | None:
    """The text of the scenario file named on the command line (shipped or a path), or None."""
    from importlib import resources

    from rcmplan.scene.scenario import scenario_names

    if source in scenario_names():
        return resources.files("rcmplan.scenarios").joinpath(f"{source}.toml").read_text()
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


def print_summary(result: RunResult) -> None:
    """A per-phase table of the run's figures."""
    from rcmplan.cli.robot import table

    s = result.summary()
    rows = [
        [
            p["name"],
            _um(p["max_rcm_deviation_m"]),
            _um(p["rms_rcm_deviation_m"]),
            _um(p["final_tip_error_m"]),
            str(p["iterations"]),
            f"{1e3 * p['wall_time_s']:.2f}",
        ]
        for p in s["phases"]
    ]
    head = [
        "phase",
        "max RCM dev [um]",
        "RMS RCM dev [um]",
        "tip error [um]",
        "iterations",
        "wall [ms]",
    ]
    print(
        f"scenario {s['scenario']}  method {s['method']}  plant {s['plant']}  status {s['status']}"
    )
    print(table(head, rows))
    print(
        f"inside the eye: max RCM deviation {_um(s['max_rcm_deviation_m'])} um, "
        f"max tip error {_um(s['max_tip_error_m'])} um; {s['iterations']} iterations, "
        f"{1e3 * s['wall_time_s']:.1f} ms"
    )


def print_json(obj: Any) -> None:
    """JSON to stdout."""
    from rcmplan.analysis.report import jsonable

    print(json.dumps(jsonable(obj), indent=2))


def _um(v: float | None) -> str:
    return "-" if v is None else f"{v * 1e6:.4g}"
