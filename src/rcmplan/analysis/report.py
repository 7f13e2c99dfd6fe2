"""Run outputs: the log (NPZ, CSV), summary.json, figures and a self-contained HTML report."""

from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from rcmplan._atomic import write_text
from rcmplan.analysis import plots
from rcmplan.analysis.result import RunResult
from rcmplan.control.log import RunLog
from rcmplan.exceptions import InvalidInputError, OutputError
from rcmplan.scene.record import scene_record


def prepare_folder(out: str | Path) -> Path:
    """Create the output folder, or raise naming it if it cannot be written."""
    path = Path(out)
    try:
        path.mkdir(parents=True, exist_ok=True)
        # A nameless file where the system has them (Linux O_TMPFILE): an interrupt cannot
        # leave the probe behind.
        tempfile.TemporaryFile(dir=path).close()
    except OSError as exc:
        raise InvalidInputError("output folder", str(path), f"a writable folder ({exc})") from exc
    return path


CSV_SKIPPED = (
    "not written: the run was interrupted (log.npz holds every record; "
    "rcmplan.RunLog.load_npz('log.npz').save_csv('log.csv') writes it)"
)


def write_summary(result: RunResult, out: Path, csv: bool = True) -> Path:
    """summary.json (and the log files, `write_log`) first, so an early stop still leaves
    them."""
    about_log = write_log(result.log, out, csv)
    return write_json(out / "summary.json", {**summary_json(result), **about_log})


def write_log(log: RunLog, out: Path, csv: bool = True) -> dict[str, str]:
    """log.npz and log.csv in out. Without `csv` (an interrupted run, to answer the signal at
    once: the CSV of a 54,000-record run takes seconds) log.csv is not written and an earlier
    run's is removed; returns what the summary then says of it (`log_csv`), else {}."""
    log.save_npz(out / "log.npz")
    if csv:
        log.save_csv(out / "log.csv")
        return {}
    (out / "log.csv").unlink(missing_ok=True)
    return {"log_csv": CSV_SKIPPED}


def summary_json(result: RunResult) -> dict[str, Any]:
    """The run summary with a unit in every key: the slider block per actuator, named as the
    robot names them (iRAM!S: `_m` for the linear sliders L1..L5, `_rad` for q5; an arm: its
    joints, `_rad` for a revolute one, `_m` for a slide), the run's simulated time, and the
    scene the run moved in (eye, trocar, named points: `rcmplan.scene.record`)."""
    s = dict(result.summary())
    used = s.get("sliders", {})
    if used:
        robot = result.robot
        s["sliders"] = {
            name: {f"{k}_{unit}": used[k][i] for k in ("lower_used", "upper_used", "min_margin")}
            for i, (name, unit) in enumerate(
                zip(robot.actuator_names, robot.actuator_units, strict=True)
            )
        }
    log = result.log
    s["simulated_time_s"] = float(log.time[-1]) if len(log) else 0.0
    s["scene"] = scene_record(result.scenario, result.robot)
    return s


def write_json(path: Path, doc: Any) -> Path:
    """doc as strict JSON (`jsonable`), written atomically; returns the path."""
    return write_text(path, json.dumps(jsonable(doc), indent=2))


def jsonable(obj: Any) -> Any:
    """obj with tuples as lists and non-finite floats as None, ready for strict JSON."""
    if isinstance(obj, dict):
        return {k: jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [jsonable(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def write_figures(result: RunResult, out: Path) -> dict[str, Path]:
    """The run's figures as PNG files in out/figures (drawn side by side where possible)."""
    from functools import partial

    from rcmplan.analysis.parallel import run_jobs

    figs = out / "figures"
    eye = result.scenario.eye(result.robot)
    log = result.log
    if len(log) == 0:
        return {}
    jobs: dict[str, tuple[Path, Any]] = {}
    if any(p.inside_eye for p in result.phases):
        path = figs / "rcm_deviation.png"
        jobs["rcm_deviation"] = (
            path, partial(plots.rcm_deviation_envelope, log, eye, path, rcm_bounds(result))
        )  # fmt: skip
        path = figs / "rcm_trace.png"
        jobs["rcm_trace"] = (path, partial(plots.rcm_trace, log, eye, path))
    targets = visited_points(log, result.scenario.points(eye).as_dict())
    path = figs / "tip_path.png"
    jobs["tip_path"] = (path, partial(plots.tip_path, log, eye, targets, path, tip_bounds(result)))
    figs.mkdir(parents=True, exist_ok=True)
    plots.style.plt()  # import matplotlib once, before any fork
    return dict(zip(jobs, run_jobs(list(jobs.values())), strict=True))


def visited_points(log: RunLog, points: dict[str, Any], tol_m: float = 1e-6) -> dict[str, Any]:
    """The named points that some commanded tip target reaches (within tol_m)."""
    cmd = log.target_tip[np.all(np.isfinite(log.target_tip), axis=1)]
    return {
        name: p
        for name, p in points.items()
        if cmd.size and np.min(np.linalg.norm(cmd - np.asarray(p), axis=1)) <= tol_m
    }


def rcm_bounds(result: RunResult) -> list[tuple[str, float]]:
    """Bounds on the RCM deviation, in [m]: the trocar port, and the QP's tolerance."""
    eye = result.scenario.eye(result.robot)
    bounds = [("trocar radius", eye.trocar_radius)]
    if result.scenario.method == "qp":
        from rcmplan.control.qp_limits import QpLimits

        extra = result.scenario.method_settings.extra
        tol = extra["rcm_tolerance_um"] * 1e-6 if "rcm_tolerance_um" in extra else None
        bounds.append(("QP RCM tolerance", tol or QpLimits().rcm_tolerance))
    return bounds


def tip_bounds(result: RunResult) -> list[tuple[str, float]]:
    """Bound on a waypoint's tip error, in [m]: the reach bound of the loop tolerance."""
    from rcmplan.analysis.limits import reach_bound

    return [("reach bound", reach_bound(result.scenario.method_settings.tolerance, result.robot))]


def write_report(
    result: RunResult, out: Path, figures: dict[str, Path], scenario_text: str | None = None
) -> Path:
    """report.html with the figures embedded, the tables, the settings and the scenario."""
    from rcmplan.analysis.report_html import render

    html = render(result, summary_json(result), figures, scenario_text)
    return write_text(out / "report.html", html)


def write_outputs(
    result: RunResult, out: str | Path, figures: bool = True, scenario_text: str | None = None
) -> dict[str, Path]:
    """Everything for a run in `out`: log, summary, figures, report (with the scenario file
    echoed when its text is given). A file that cannot be written (a full disk) raises
    OutputError naming it; files are written atomically, so none is left half-written."""
    folder = prepare_folder(out)
    try:
        made = {"summary": write_summary(result, folder)}
        if figures:
            figs = write_figures(result, folder)
            made.update(figs)
            made["report"] = write_report(result, folder, figs, scenario_text)
    except OSError as exc:
        raise OutputError(exc.filename or folder, exc.strerror or str(exc)) from exc
    return made
