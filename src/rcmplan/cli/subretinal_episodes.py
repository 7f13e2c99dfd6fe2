"""`rcmplan subretinal --episodes N`: N episodes with drawn conditions, every compensation method
on each, on local processes or a Dask cluster, checkpointed (--resume continues).

An option among --ioct-rate-hz, --latency-ms, --motion-um, --eye-drift-um and --target-fraction
fixes that condition instead of drawing it. Interrupted (SIGINT, SIGTERM) or failed, the run
writes summary.json and the per-episode log of what finished, with status "interrupted" or
the error's own (`scheduler_error`, `worker_lost`, ...) and why; the finished episodes stay in
the checkpoint.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rcmplan._validate import integer
from rcmplan.analysis.units import fmt
from rcmplan.cli import interrupts
from rcmplan.cli.common import SEED_MAX
from rcmplan.cli.output import finish, one_line, progress_bar, table
from rcmplan.exceptions import RcmplanError

if TYPE_CHECKING:
    from rcmplan.subretinal.episode_batch import BatchResult, BatchSettings, EpisodeCheckpoint


def batch_of(args: argparse.Namespace) -> BatchSettings:
    """The batch from the options (checked; a given condition is fixed, not drawn)."""
    from rcmplan.cli.subretinal_settings import settings_of
    from rcmplan.subretinal.episode_batch import MAX_EPISODES, METHODS, BatchSettings
    from rcmplan.subretinal.episode_draws import DrawRanges

    base = settings_of(args)
    methods = METHODS if args.compensation in (None, "all") else (args.compensation,)
    fixed: dict[str, tuple[float, float]] = {}
    if args.ioct_rate_hz is not None:
        fixed["ioct_rate_hz"] = (base.ioct_rate_hz, base.ioct_rate_hz)
    if args.latency_ms is not None:
        fixed["latency_s"] = (base.latency_s, base.latency_s)
    if args.motion_um is not None:
        fixed["breathing_amplitude_m"] = (base.breathing_m, base.breathing_m)
        fixed["cardiac_amplitude_m"] = (base.cardiac_m, base.cardiac_m)
    if args.eye_drift_um is not None:
        fixed["eye_drift_m"] = (base.eye_drift_m, base.eye_drift_m)
    if args.target_fraction is not None:
        fixed["target_fraction"] = (base.target_fraction, base.target_fraction)
    episodes = integer("--episodes", args.episodes, 1, MAX_EPISODES)
    seed = integer("--seed", args.seed, 0, SEED_MAX)
    return BatchSettings(episodes=episodes, seed=seed, methods=methods,
                         ranges=DrawRanges(**fixed), base=base)  # fmt: skip


def run_episodes(args: argparse.Namespace) -> int:
    """Run the batch, write summary.json, episodes.csv, episodes.json and the curves."""
    from rcmplan.analysis.report import prepare_folder
    from rcmplan.cli.batch_options import (
        check_batch_options,
        checkpoint_path,
        open_checkpoint,
        resume_record,
    )
    from rcmplan.cli.subretinal_settings import write_failed
    from rcmplan.subretinal.episode_batch import EpisodeCheckpoint
    from rcmplan.sweep.checkpoint import HEADER

    out = prepare_folder(args.out)
    try:
        check_batch_options(args)
        batch = batch_of(args)
        path = checkpoint_path(args, out)
        header_found = (path / HEADER).is_file()
        checkpoint = open_checkpoint(path, batch, args.resume, EpisodeCheckpoint)
    except RcmplanError as exc:
        write_failed(out, exc.status, f"{type(exc).__name__}: {exc}")
        raise
    if args.resume and not checkpoint.load():
        note = resume_record(path, True, header_found, 0, "batch")["message"]
        print(f"rcmplan subretinal: {note}", file=sys.stderr)
    try:
        with interrupts.surfaced():
            result = run_main(args, batch, checkpoint)
            resumed = resume_record(path, args.resume, header_found, result.resumed, "batch")
            doc = write_outputs(args, out, result, checkpoint, resumed)
            interrupts.finished()  # inside the handling below: no instant falls between
    except KeyboardInterrupt as exc:
        why = f"interrupted by {interrupts.signal_name(exc)}"
        write_partial(out, batch, checkpoint, "interrupted", why)
        raise
    except RcmplanError as exc:
        write_partial(out, batch, checkpoint, exc.status, f"{type(exc).__name__}: {exc}")
        raise
    return finish(args, out, doc, lambda: print_tables(doc), None)


def run_main(args: argparse.Namespace, batch: BatchSettings, checkpoint: EpisodeCheckpoint
             ) -> BatchResult:  # fmt: skip
    """The batch on the chosen executor, with a progress bar over jobs."""
    from rcmplan.subretinal.episode_batch import PRELOAD, run_batch
    from rcmplan.sweep.executors import make_executor

    with (
        make_executor(args.workers, args.scheduler, args.timeout, PRELOAD) as executor,
        progress_bar("subretinal episodes", "episode") as bar,
    ):
        bar.reset(total=batch.n_items)
        bar.update(len(checkpoint.load()))
        return run_batch(batch, executor, checkpoint, lambda rs: bar.update(len(rs)))


def write_outputs(
    args: argparse.Namespace,
    out: Path,
    result: BatchResult,
    checkpoint: EpisodeCheckpoint,
    resumed: dict[str, Any],
) -> dict[str, Any]:
    """summary.json (with the resume record `resumed`, `batch_options.resume_record`), the
    per-episode log and, unless --no-plots, the curves; the summary."""
    from rcmplan._atomic import write_text
    from rcmplan.analysis.report import jsonable
    from rcmplan.subretinal.episode_report import batch_summary, write_records

    records = result.ordered()
    doc: dict[str, Any] = {"command": "subretinal", "status": "ok", "message": "",
                           **batch_summary(result.settings, records)}  # fmt: skip
    per_run = [r.wall_time_s for r in records]
    doc.update(executor=result.executor, wall_time_s=result.wall_time_s, resumed=resumed,
               checkpoint=str(checkpoint.path),
               run_wall_time_s_mean=sum(per_run) / len(per_run) if per_run else None)  # fmt: skip
    doc["files"] = {k: str(v) for k, v in write_records(records, out).items()}
    if not args.no_plots:
        from rcmplan.subretinal.episode_curves import curve_figures

        figures = curve_figures(doc["curves"], out / "figures")
        doc["figures"] = {k: str(v) for k, v in figures.items()}
    doc = jsonable(doc)
    write_text(out / "summary.json", json.dumps(doc, indent=2))
    return doc


def write_partial(out: Path, batch: BatchSettings, checkpoint: EpisodeCheckpoint, status: str,
                  why: str) -> None:  # fmt: skip
    """summary.json and the per-episode log of the finished jobs of a stopped batch."""
    from rcmplan.analysis.report import write_json
    from rcmplan.subretinal.episode_report import batch_summary, write_records

    with interrupts.shielded():
        try:
            records = list(checkpoint.load().values())
        except RcmplanError:
            records = []
        message = (f"{one_line(why)}; {len(records)} of {batch.n_items} finished episode runs "
                   f"are kept in {checkpoint.path}; rerun with --resume to continue")  # fmt: skip
        doc = {"command": "subretinal", "status": status, "message": message,
               **batch_summary(batch, records),
               "checkpoint": str(checkpoint.path)}  # fmt: skip
        write_records(records, out)
        write_json(out / "summary.json", doc)
        print(f"rcmplan subretinal: {message}", file=sys.stderr)


def _um(value: float | None) -> str:
    return fmt(value, "um", with_unit=True)


def _pct(value: float | None) -> str:
    return "-" if value is None else f"{100 * value:.1f} %"


def print_tables(doc: dict[str, Any]) -> None:
    """Per method, then the curves against the iOCT rate and latency."""
    rows = [[name, m["episodes"], _pct(m["success_rate"]), m["rpe_breaches"],
             _um(m["tracking_rms_m_median"]), _um(m["depth_error_m_median"]),
             _um(m["depth_rms_error_m_median"]), _um(m["max_rcm_deviation_m"])]
            for name, m in doc["methods"].items()]  # fmt: skip
    head = ["method", "episodes", "success", "RPE breaches", "tracking RMS (median)",
            "depth error (median)", "depth RMS (median)", "max RCM deviation"]  # fmt: skip
    print(f"subretinal episodes: {doc['episodes_planned']} drawn, {doc['jobs_run']} runs, "
          f"{doc.get('executor', '')}, {doc.get('wall_time_s', 0.0):.1f} s")  # fmt: skip
    print(table(head, rows))
    print(f"best: {doc['method']} ({doc['method_choice']})")
    for name, (unit, scale) in {"ioct_rate_hz": ("Hz", 1.0), "latency_s": ("ms", 1e3)}.items():
        e, per = doc["curves"][name]["edges"], doc["curves"][name]["methods"]
        methods = list(per)
        rows = []
        for b in range(len(e) - 1):
            cells = [f"{_pct(per[m]['success_rate'][b])}, {_um(per[m]['tracking_rms_m_median'][b])}"
                     for m in methods]  # fmt: skip
            n = per[methods[0]]["episodes"][b]
            rows.append([f"{scale * e[b]:.3g}-{scale * e[b + 1]:.3g} {unit}", n, *cells])
        print(f"\nsuccess, median tracking RMS against {name}")
        print(table([name, "episodes", *methods], rows))
