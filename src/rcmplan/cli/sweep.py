"""`rcmplan sweep`: retina targets over the reachable workspace, maps and an optional gain search.

Runs on local processes (every core by default) or, with --scheduler, on a Dask cluster. Every
finished chunk is written to the checkpoint folder at once; --resume continues it.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from rcmplan._validate import integer, scalar
from rcmplan.cli import interrupts
from rcmplan.cli.batch_options import (
    add_batch_options,
    check_batch_options,
    checkpoint_path,
    open_checkpoint,
    resume_record,
)
from rcmplan.cli.common import (
    SEED_MAX,
    add_json,
    add_method,
    add_no_plots,
    add_out,
    add_plant,
    add_robot,
    add_scenario,
    announce_robot,
)
from rcmplan.cli.output import one_line, print_json, progress_bar
from rcmplan.cli.sweep_outputs import (
    print_tables,
    write_interrupted,
    write_outputs,
)
from rcmplan.exceptions import RcmplanError
from rcmplan.sweep.settings import (
    MAX_TARGETS,
    SAMPLINGS,
    MotionSettings,
    Region,
    SweepSettings,
)

if TYPE_CHECKING:
    from rcmplan.sweep.checkpoint import Checkpoint
    from rcmplan.sweep.executors import Executor
    from rcmplan.sweep.gains import GainSearchResult
    from rcmplan.sweep.runner import SweepResult
    from rcmplan.sweep.sampling import Sample
    from rcmplan.sweep.task import TargetResult


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `sweep` subcommand."""
    p = sub.add_parser(
        "sweep", help="accuracy and convergence maps over the retina, and a gain search",
        description="Run the insert-and-visit motion to retina targets sampled over the region "
        "reachable through the trocar; write maps, a summary and per-target results. Each "
        "target runs with the scenario's controller settings, as inject and compare do: gains, "
        "tolerances, iteration cap, RCM bound (rcm_bound_um), RCM step tolerance "
        "(rcm_tolerance_um) and [qp] options (summary.json's settings.motion lists them); "
        "--robot, --method and --plant, when given, replace the scenario's. A rerun "
        "into the same folder starts afresh; --resume continues its checkpoint.",
    )  # fmt: skip
    add_scenario(p)
    add_robot(p)
    add_method(p)
    add_plant(p)
    p.add_argument("--targets", type=int, default=1000, help="rays sampled (1000)")
    p.add_argument("--max-angle", type=float, default=25.0, metavar="DEG",
                   help="half-angle of the cone of rays around the insertion axis, 0-90 deg "
                   "(25)")  # fmt: skip
    p.add_argument("--sampling", choices=SAMPLINGS, default="grid", help="ray sampling (grid)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random sampling (0)")
    add_batch_options(p, "sweep")
    p.add_argument("--gain-search", choices=("none", "grid", "optimize"), default="none",
                   help="search K and the step size on a subsample (none)")  # fmt: skip
    p.add_argument("--subsample", type=int, default=16, help="targets per gain candidate (16)")
    p.add_argument("--max-evaluations", type=int, default=30,
                   help="candidates the optimiser may evaluate (30)")  # fmt: skip
    p.add_argument("--rcm-bound", type=float, default=10.0, metavar="UM",
                   help="gain search: largest RCM deviation a candidate may reach to be "
                   "accepted, in um (10); the runs' own RCM bound, which ends a target's run, is "
                   "the scenario's rcm_bound_um")  # fmt: skip
    add_out(p, "sweep")
    add_json(p)
    add_no_plots(p)
    p.set_defaults(run=run)


def settings_from_args(args: argparse.Namespace) -> SweepSettings:
    """Region and motion settings from the command line and the scenario (its controller
    settings, RCM bound and tolerance included; --robot, --method and --plant, when given, in
    place of its own), each option checked under its own name and in the unit it is typed in."""
    from rcmplan.scene.scenario import load_scenario

    sc = load_scenario(args.scenario)
    if args.robot:  # refused if the scenario states its contacts in its own robot's base frame
        sc = sc.with_robot(args.robot)
    changes = {k: getattr(args, k) for k in ("robot", "method", "plant") if getattr(args, k)}
    announce_robot(changes.get("robot", sc.robot), "sweep")
    angle = scalar("--max-angle", args.max_angle, 0.0, 90.0, low_open=True, high_open=True)
    targets = integer("--targets", args.targets, 1, MAX_TARGETS)
    seed = integer("--seed", args.seed, 0, SEED_MAX)
    region = Region(math.radians(angle), targets, args.sampling, seed)
    return SweepSettings(region, MotionSettings.from_scenario(sc, **changes))


def check_search_options(args: argparse.Namespace) -> None:
    """The gain search's options, each under its own name and unit (before any motion)."""
    from rcmplan.sweep.gains import RCM_BOUND_MAX_M

    integer("--subsample", args.subsample, 1, MAX_TARGETS)
    integer("--max-evaluations", args.max_evaluations, 1, 10_000)
    scalar("--rcm-bound", args.rcm_bound, 0.0, 1e6 * RCM_BOUND_MAX_M, low_open=True)


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


REACH_ROLLS = 12  # needle rolls tried per retina point by the curved needle's reach map


def run_curved_reach(args: argparse.Namespace, out: Path) -> int | None:
    """A curved needle's scenario: the reach map from poses (`rcmplan.scene.reach`, --targets
    points over the retinal sphere) beside the straight shaft's; None for a straight needle."""
    from rcmplan._atomic import write_text
    from rcmplan.control.curved import curved
    from rcmplan.robot.registry import make_robot
    from rcmplan.scene.reach import reach_map
    from rcmplan.scene.scenario import load_scenario

    sc = load_scenario(args.scenario)
    if sc.needle.kind != "curved":
        return None
    if args.robot:
        sc = sc.with_robot(args.robot)
    points = integer("--targets", args.targets, 1, MAX_TARGETS)
    robot = curved(sc.needle.fit(make_robot(sc.robot)))
    m = reach_map(robot, sc.eye(robot), n=points, rolls=REACH_ROLLS)
    s = {"command": "sweep", "status": "ok", "message": "", "scenario": sc.name,
         "robot": robot.name, "needle": "curved", "radius_m": sc.needle.radius,
         "arc_angle_rad": sc.needle.arc_angle, "lattice_points": points, "rolls": REACH_ROLLS,
         **m.summary()}  # fmt: skip
    write_text(out / "summary.json", json.dumps(s, indent=2))
    interrupts.finished()
    if args.json:
        print_json(s)
    else:
        from rcmplan.analysis.units import fmt

        for key, value in s.items():
            print(f"{key:32s} {fmt(value) if isinstance(value, float) else value}")
    return 0


def run(args: argparse.Namespace) -> int:
    """Run the sweep (and the gain search), write the outputs, print the tables.

    Refused (bad options, no reachable target, a scheduler that does not answer), it writes
    summary.json with the error's status and re-raises (exit 2). Interrupted (SIGINT,
    SIGTERM), it stops the workers, writes summary.json with status "interrupted" (the
    finished results stay in the checkpoint for --resume) and re-raises the interrupt (exit
    130 or 143).
    """
    from rcmplan.analysis.report import prepare_folder

    out = prepare_folder(args.out)
    try:
        check_options(args)
        reach = run_curved_reach(args, out)
        if reach is not None:
            return reach
        return run_straight(args, out)
    except RcmplanError as exc:
        with interrupts.shielded():
            doc = {"scenario": args.scenario, "status": exc.status,
                   "message": one_line(f"{type(exc).__name__}: {exc}")}  # fmt: skip
            interrupts.write_stop_file(out, "sweep", doc)
        raise


def check_options(args: argparse.Namespace) -> None:
    """The options a sweep's settings do not hold, each under its own name and unit."""
    check_batch_options(args)
    if args.gain_search != "none":
        check_search_options(args)


def run_straight(args: argparse.Namespace, out: Path) -> int:
    """The sweep of a straight needle: targets on the executor, checkpointed, then the maps."""
    from rcmplan.sweep.checkpoint import HEADER, Checkpoint
    from rcmplan.sweep.executors import make_executor

    settings = settings_from_args(args)
    path = checkpoint_path(args, out)
    header_found = (path / HEADER).is_file()
    checkpoint = open_checkpoint(path, settings, args.resume, Checkpoint)
    if args.resume and not checkpoint.chunk_files():
        note = resume_record(path, True, header_found, 0)["message"]
        print(f"rcmplan sweep: {note}", file=sys.stderr)
    try:
        with interrupts.surfaced():
            with make_executor(args.workers, args.scheduler, args.timeout) as executor:
                result = run_main(args, settings, checkpoint, executor)
                gains = None if args.gain_search == "none" else run_gains(
                    args, result, checkpoint, executor)  # fmt: skip
            resumed = resume_record(path, args.resume, header_found, result.resumed)
            s = write_outputs(args, out, result, gains, resumed)
            interrupts.finished()  # inside the handling below: no instant falls between
    except KeyboardInterrupt as exc:
        write_interrupted(out, checkpoint, exc)
        raise
    if args.json:
        print_json(s)
    else:
        print_tables(s, gains)
        print(f"outputs in {out}/")
    return 0
