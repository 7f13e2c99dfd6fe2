"""`rcmplan sweep`: retina targets over the reachable workspace, maps and an optional gain search.

Runs on local processes (every core by default) or, with --scheduler, on a Dask cluster. Every
finished chunk is written to the checkpoint folder at once; --resume continues it.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import shutil
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rcmplan.cli import interrupts
from rcmplan.control.methods import METHODS
from rcmplan.exceptions import RcmplanError
from rcmplan.sim.registry import PLANTS
from rcmplan.sweep.executors import DEFAULT_TIMEOUT_S
from rcmplan.sweep.settings import SAMPLINGS, MotionSettings, Region, SweepSettings

if TYPE_CHECKING:
    from rcmplan.sweep.checkpoint import Checkpoint
    from rcmplan.sweep.executors import Executor
    from rcmplan.sweep.gains import GainSearchResult
    from rcmplan.sweep.runner import SweepResult
    from rcmplan.sweep.sampling import Sample
    from rcmplan.sweep.task import TargetResult

OUT_DEFAULT = "rcmplan-out/sweep"


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `sweep` subcommand."""
    p = sub.add_parser(
        "sweep",
        help="accuracy and convergence maps over the retina, and a gain search",
        description="Run the insert-and-visit motion to retina targets sampled over the region "
        "reachable through the trocar; write maps, a summary and per-target results.",
    )
    p.add_argument("--scenario", default="default", help="scenario name or TOML file (default)")
    p.add_argument("--targets", type=int, default=1000, help="rays sampled (1000)")
    p.add_argument(
        "--max-angle",
        type=float,
        default=25.0,
        help="half-angle of the cone of rays around the insertion axis [deg] (25)",
    )
    p.add_argument("--sampling", choices=SAMPLINGS, default="grid", help="ray sampling (grid)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random sampling (0)")
    p.add_argument("--method", choices=METHODS, help="control method (default: the scenario's)")
    p.add_argument("--plant", choices=sorted(PLANTS),
                   help="plant each target runs on (default: the scenario's)")  # fmt: skip
    p.add_argument("--workers", type=int, help="local processes (default: every core)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler address (tcp://...)")
    p.add_argument(
        "--timeout",
        type=float,
        default=DEFAULT_TIMEOUT_S,
        help=f"Dask: time [s] to connect, and to wait for a worker when none is left "
        f"(positive, finite; {DEFAULT_TIMEOUT_S:g})",
    )
    p.add_argument("--checkpoint", metavar="PATH", help="checkpoint folder (OUT/checkpoint)")
    p.add_argument("--resume", action="store_true", help="continue an existing checkpoint")
    p.add_argument("--overwrite", action="store_true",
                   help="discard an existing checkpoint of any settings, start afresh")  # fmt: skip
    p.add_argument(
        "--gain-search",
        choices=("none", "grid", "optimize"),
        default="none",
        help="search K and the step size on a subsample (none)",
    )
    p.add_argument("--subsample", type=int, default=16, help="targets per gain candidate (16)")
    p.add_argument(
        "--max-evaluations", type=int, default=30, help="candidates the optimiser may evaluate (30)"
    )
    p.add_argument(
        "--rcm-bound",
        type=float,
        default=10.0,
        help="gain search: largest accepted RCM deviation [um] (10)",
    )
    p.add_argument("--out", default=OUT_DEFAULT, help=f"output folder ({OUT_DEFAULT})")
    p.add_argument("--json", action="store_true", help="print summary.json instead of tables")
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    p.set_defaults(run=run)  # fmt: skip


def settings_from_args(args: argparse.Namespace) -> SweepSettings:
    """Region and motion settings from the command line and the scenario."""
    from rcmplan.scene.scenario import load_scenario

    sc = load_scenario(args.scenario)
    changes = {k: getattr(args, k) for k in ("method", "plant") if getattr(args, k, None)}
    region = Region(math.radians(args.max_angle), args.targets, args.sampling, args.seed)
    return SweepSettings(region, MotionSettings.from_scenario(sc, **changes))


class _NoBar:
    """Stands in for a tqdm bar when tqdm (extra "progress") is not installed."""

    def reset(self, total: int | None = None) -> None:
        """Nothing to show."""

    def update(self, n: int = 1) -> None:
        """Nothing to show."""


@contextlib.contextmanager
def progress_bar(label: str, unit: str) -> Iterator[Any]:
    """A tqdm bar on stderr that appears after a second, only on a terminal."""
    try:
        from tqdm import tqdm
    except ImportError:
        yield _NoBar()
        return
    bar = tqdm(desc=label, unit=unit, delay=1.0, file=sys.stderr, leave=False,
               disable=not sys.stderr.isatty())  # fmt: skip
    try:
        yield bar
    finally:
        bar.close()


def run_main(args: argparse.Namespace, settings: SweepSettings, checkpoint: Checkpoint,
             executor: Executor) -> SweepResult:  # fmt: skip
    """The sweep itself, with a progress bar over targets."""
    from rcmplan.sweep.runner import run_sweep

    with progress_bar("sweep", "target") as bar:

        def on_sample(sample: Sample) -> None:
            bar.reset(total=int(sample.reachable_ids.size))

        def on_chunk(results: list[TargetResult]) -> None:
            bar.update(len(results))

        return run_sweep(settings, executor, checkpoint, on_chunk, on_sample)


def run_gains(args: argparse.Namespace, result: SweepResult, checkpoint: Checkpoint,
              executor: Executor) -> GainSearchResult:  # fmt: skip
    """The gain search on a subsample, checkpointed per candidate under the checkpoint."""
    from rcmplan.sweep.gains import Objective, Search, grid_search, optimize_search, subsample

    ids = subsample(result.sample, args.subsample)
    with progress_bar(f"gain search ({args.gain_search})", "candidate") as bar:
        search = Search(
            result.settings, result.sample, ids, executor,
            Objective(rcm_bound_m=args.rcm_bound * 1e-6),
            checkpoint_root=str(checkpoint.path / "gains"),
            on_evaluation=lambda _e: bar.update(1),
        )  # fmt: skip
        if args.gain_search == "grid":
            return grid_search(search)
        return optimize_search(search, args.max_evaluations)


def write_outputs(
    args: argparse.Namespace, out: Path, result: SweepResult, gains: GainSearchResult | None
) -> dict[str, Any]:
    """summary.json, targets.csv, gains.json and the figures; returns the summary."""
    from rcmplan._atomic import write_text
    from rcmplan.analysis.report import jsonable
    from rcmplan.sweep import report

    s = {"status": "ok", "message": "", **report.summary(result)}
    if gains is not None:
        s["gain_search"] = report.gain_summary(gains)
    write_text(out / "summary.json", json.dumps(jsonable(s), indent=2))
    report.write_targets_csv(result, out / "targets.csv")
    if not args.no_plots:
        from rcmplan.sweep import maps

        figs = maps.sweep_maps(result, out / "figures")
        if gains is not None:
            figs["gains"] = maps.gain_tradeoff(gains, out / "figures" / "gains.png")
        s["figures"] = {k: str(v) for k, v in figs.items()}
    return s


def print_tables(s: dict[str, Any], gains: GainSearchResult | None) -> None:
    """The summary table and, after a gain search, the candidates table."""
    from rcmplan.cli.robot import table
    from rcmplan.sweep import report

    print(table(["figure", "value", "unit"], report.summary_rows(s)))
    if gains is not None:
        print(f"\ngain search ({gains.mode}): {s['gain_search']['objective']} "
              f"({1e6 * gains.objective.rcm_bound_m:g} um); {gains.message}")  # fmt: skip
        print(table(report.GAIN_HEADER, report.gain_rows(gains)))
        if gains.best is None:
            print("no candidate met the constraints")


def open_checkpoint(path: Path, settings: SweepSettings, args: argparse.Namespace) -> Checkpoint:
    """Open the checkpoint: --overwrite discards an old one first; without --resume or
    --overwrite, an old checkpoint of other settings or with results is a clear error."""
    from rcmplan.sweep.checkpoint import HEADER, Checkpoint
    from rcmplan.sweep.errors import CheckpointError

    if args.resume and args.overwrite:
        raise CheckpointError(path, "--resume and --overwrite exclude each other")
    if args.overwrite and path.exists():
        if path.is_dir() and not any(path.iterdir()):
            pass
        elif not (path / HEADER).is_file():
            raise CheckpointError(path, "is not a checkpoint folder (no header.json); not removed")
        else:
            shutil.rmtree(path)
    try:
        return Checkpoint.open(path, settings, args.resume)
    except CheckpointError as exc:
        hint = "" if args.resume else "; or rerun with --overwrite to discard it"
        raise CheckpointError(exc.path, exc.problem + hint) from exc


REACH_ROLLS = 12  # needle rolls tried per retina point by the curved needle's reach map


def run_curved_reach(args: argparse.Namespace, out: Path) -> int | None:
    """A curved needle's scenario: the reach map from poses (`rcmplan.scene.reach`, --targets
    points over the retinal sphere) beside the straight shaft's; None for a straight needle."""
    import json

    from rcmplan.control.curved import curved
    from rcmplan.robot.registry import make_robot
    from rcmplan.scene.reach import reach_map
    from rcmplan.scene.scenario import load_scenario

    sc = load_scenario(args.scenario)
    if sc.needle.kind != "curved":
        return None
    robot = curved(sc.needle.fit(make_robot(sc.robot)))
    m = reach_map(robot, sc.eye(robot), n=args.targets, rolls=REACH_ROLLS)
    s = {"scenario": sc.name, "robot": robot.name, "needle": "curved",
         "radius_m": sc.needle.radius, "arc_angle_rad": sc.needle.arc_angle,
         "lattice_points": args.targets, "rolls": REACH_ROLLS, **m.summary()}  # fmt: skip
    (out / "summary.json").write_text(json.dumps(s, indent=2))
    if args.json:
        from rcmplan.cli.common import print_json

        print_json(s)
    else:
        from rcmplan.analysis.units import fmt

        for key, value in s.items():
            print(f"{key:32s} {fmt(value) if isinstance(value, float) else value}")
    return 0


def run(args: argparse.Namespace) -> int:
    """Run the sweep (and the gain search), write the outputs, print the tables.

    Interrupted (SIGINT, SIGTERM), it stops the workers, writes summary.json with status
    "interrupted" (the finished results stay in the checkpoint for --resume) and re-raises
    the interrupt (exit 130 or 143).
    """
    from rcmplan.analysis.report import prepare_folder
    from rcmplan.sweep.executors import check_timeout, make_executor

    check_timeout(args.timeout)
    out = prepare_folder(args.out)
    reach = run_curved_reach(args, out)
    if reach is not None:
        return reach
    settings = settings_from_args(args)
    checkpoint = open_checkpoint(Path(args.checkpoint or out / "checkpoint"), settings, args)
    try:
        with interrupts.surfaced():
            with make_executor(args.workers, args.scheduler, args.timeout) as executor:
                result = run_main(args, settings, checkpoint, executor)
                gains = None if args.gain_search == "none" else run_gains(
                    args, result, checkpoint, executor)  # fmt: skip
            s = write_outputs(args, out, result, gains)
    except KeyboardInterrupt as exc:
        write_interrupted(out, checkpoint, exc)
        raise
    interrupts.finished()
    if args.json:
        from rcmplan.cli.common import print_json

        print_json(s)
    else:
        print_tables(s, gains)
        print(f"outputs in {out}/")
    return 0


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
        doc = {"status": "interrupted", "message": message, "checkpoint": str(checkpoint.path),
               "results_kept": kept}  # fmt: skip
        write_text(out / "summary.json", json.dumps(doc, indent=2))
        print(f"rcmplan sweep: {message}", file=sys.stderr)
