"""Run outputs: the log (NPZ, CSV), summary.json, figures and a self-contained HTML report."""

from __future__ import annotations

import base64
import html
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from rcmplan import __version__
from rcmplan.analysis import plots
from rcmplan.control.log import RunLog
from rcmplan.exceptions import InvalidInputError
from rcmplan.job import RunResult


def prepare_folder(out: str | Path) -> Path:
    """Create the output folder, or raise naming it if it cannot be written."""
    path = Path(out)
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / ".write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as exc:
        raise InvalidInputError("output folder", str(path), f"a writable folder ({exc})") from exc
    return path


def write_summary(result: RunResult, out: Path) -> Path:
    """summary.json (and the log files) first, so an early stop still leaves them."""
    result.log.save_npz(out / "log.npz")
    result.log.save_csv(out / "log.csv")
    path = out / "summary.json"
    path.write_text(json.dumps(jsonable(result.summary()), indent=2))
    return path


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
    """The run's figures as PNG files in out/figures."""
    figs = out / "figures"
    eye = result.scenario.eye(result.robot)
    log = result.log
    made: dict[str, Path] = {}
    if len(log) == 0:
        return made
    targets = visited_points(log, result.scenario.points(eye).as_dict())
    made["tip_path"] = plots.tip_path(log, eye, targets, figs / "tip_path.png")
    if any(p.inside_eye for p in result.phases):
        made["rcm_deviation"] = plots.rcm_deviation_envelope(
            log, eye, figs / "rcm_deviation.png", rcm_bounds(result)
        )
        made["rcm_trace"] = plots.rcm_trace(log, eye, figs / "rcm_trace.png")
    return made


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


def write_report(result: RunResult, out: Path, figures: dict[str, Path]) -> Path:
    """report.html with the figures embedded, the summary table and the settings."""
    s = result.summary()
    rows = "".join(
        "<tr>"
        + "".join(
            f"<td>{html.escape(str(v))}</td>"
            for v in (
                p["name"],
                _um(p["max_rcm_deviation_m"]),
                _um(p["rms_rcm_deviation_m"]),
                _um(p["final_tip_error_m"]),
                p["iterations"],
                f"{1e3 * p['wall_time_s']:.2f}",
            )
        )
        + "</tr>"
        for p in s["phases"]
    )
    imgs = "".join(
        f"<h3>{html.escape(name)}</h3><img alt='{html.escape(name)}' "
        f"src='data:image/png;base64,{base64.b64encode(path.read_bytes()).decode()}'>"
        for name, path in figures.items()
    )
    settings = html.escape(json.dumps(_settings(result), indent=2, default=str))
    doc = f"""<!doctype html><html><head><meta charset="utf-8">
<title>rcmplan run: {html.escape(s["scenario"])}</title>
<style>body{{font-family:sans-serif;max-width:1100px;margin:2em auto}}
table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:3px 8px;text-align:right}}
img{{max-width:100%}}</style></head><body>
<h1>rcmplan run: {html.escape(s["scenario"])}</h1>
<p>status: <b>{html.escape(s["status"])}</b> &middot; method {html.escape(s["method"])}
&middot; plant {html.escape(s["plant"])} &middot; {s["iterations"]} iterations in
{1e3 * s["wall_time_s"]:.1f} ms &middot; max RCM deviation inside the eye
{_um(s["max_rcm_deviation_m"])} um &middot; max tip error {_um(s["max_tip_error_m"])} um</p>
<table><tr><th>phase</th><th>max RCM dev [um]</th><th>RMS RCM dev [um]</th>
<th>final tip error [um]</th><th>iterations</th><th>wall [ms]</th></tr>{rows}</table>
{imgs}<h2>Settings</h2><pre>{settings}</pre>
<p>rcmplan {__version__}</p></body></html>"""
    path = out / "report.html"
    path.write_text(doc)
    return path


def _settings(result: RunResult) -> dict[str, Any]:
    sc = result.scenario
    return {
        "scenario": sc.name,
        "procedure": sc.procedure,
        "method": sc.method,
        "plant": sc.plant,
        "method_settings": sc.method_settings,
        "loop": sc.loop,
        "steps": sc.steps,
        "eye": sc.eye_options,
        "points": sc.point_options,
        "robot": result.robot.params,
    }


def _um(v: float | None) -> str:
    return "-" if v is None else f"{v * 1e6:.4g}"


def write_outputs(result: RunResult, out: str | Path, figures: bool = True) -> dict[str, Path]:
    """Everything for a run in `out`: log, summary, figures, report."""
    folder = prepare_folder(out)
    made = {"summary": write_summary(result, folder)}
    if figures:
        figs = write_figures(result, folder)
        made.update(figs)
        made["report"] = write_report(result, folder, figs)
    return made
