"""report.html: a self-contained page a colleague can read (figures embedded, no scripts).

Headline numbers, a per-phase table, the limits (violations per kind, the waypoints a limit
held back) and the code that ran, captioned figures, the settings as a table and the scenario
file echoed: the figures the command line prints (`analysis.summary_text`), and more. Every
number goes through `analysis.units.fmt`.
"""

from __future__ import annotations

import base64
import html
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rcmplan._version import __version__
from rcmplan.analysis.result import RunResult
from rcmplan.analysis.settings_table import settings_rows
from rcmplan.analysis.summary_text import (
    LIMITED_HEAD,
    VIOLATION_HEAD,
    execution_text,
    limited_rows,
    um,
    violation_rows,
    violations_label,
    violations_text,
)
from rcmplan.analysis.units import fmt

CSS = """
body{font:15px/1.45 system-ui,sans-serif;color:#222;max-width:980px;margin:1.5em auto;
padding:0 1em}
h1{font-size:1.5em;margin-bottom:.2em}h2{font-size:1.2em;margin-top:1.6em;
border-bottom:1px solid #ddd}
.status-ok{color:#006d4f}.status-bad{color:#b34700}
dl.head{display:grid;grid-template-columns:repeat(auto-fit,minmax(210px,1fr));gap:.6em;margin:0}
dl.head div{background:#f4f6f8;border-radius:6px;padding:.5em .8em}
dl.head dt{font-size:.8em;color:#555}dl.head dd{margin:0;font-size:1.25em;font-weight:600}
table{border-collapse:collapse;width:100%;font-size:.9em}
th,td{border-bottom:1px solid #e2e2e2;padding:3px 6px;text-align:right;vertical-align:top}
th{background:#f4f6f8}td.l,th.l{text-align:left}
figure{margin:1.2em 0}img{max-width:100%;height:auto}
figcaption{font-size:.9em;color:#444}
pre{white-space:pre-wrap;overflow-wrap:anywhere;background:#f7f7f7;padding:.6em;
font-size:.85em}
.wrap{overflow-wrap:anywhere}
"""

CAPTIONS = {
    "rcm_deviation": (
        "RCM deviation |p_rcm - trocar|, the largest value in each control step (black) and "
        "its components in trocar coordinates (e1, e2 across the port, n along the insertion "
        "axis), against the bounds. Time is the run's time; bands mark the phases inside "
        "the eye. Log scale; rounding noise below four decades under the peak is drawn on "
        "the axis."
    ),
    "rcm_trace": (
        "The RCM point in the plane of the trocar port (e1 = n x z_base normalised, "
        "e2 = n x e1, n the insertion axis from the trocar to the eye centre): to scale "
        "inside the port circle (left) and zoomed, coloured by time (right)."
    ),
    "tip_path": (
        "Needle tip path in the robot base frame with the retina sphere, the trocar and the "
        "named targets the procedure visits: commanded (target_tip, dashed) and actual "
        "(solid). Right: distance from the tip to the commanded point, the tracking error "
        "(largest in each control step, over its iterations: the phase table's max tracking "
        "error) and the waypoint tip error (at the step's end), against the reach bound the "
        "loop tolerance implies. Log scale; values four decades under the peak are drawn on "
        "the axis."
    ),
}


def headline(s: dict[str, Any], trocar_radius_m: float) -> list[tuple[str, str]]:
    """(label, value with unit) of the figures a reader wants first."""
    inside = s["max_rcm_deviation_m"] is not None or not s["iterations"]
    rows = [
        ("max RCM deviation inside the eye",
         um(s["max_rcm_deviation_m"]) if inside else "no record inside the eye"),
        ("trocar radius (bound)", um(trocar_radius_m)),
        ("max tip error at the targets" if inside else "max tip error at the end of a phase",
         um(s["max_tip_error_m"])),
    ]  # fmt: skip
    if "limit_violations" in s:
        rows += [
            ("max waypoint tip error", um(s["max_waypoint_tip_error_m"])),
            ("limited waypoints", f"{s['limited_waypoints']:,}"),
            (violations_label(s), violations_text(s)),
        ]
    rows += [
        ("control iterations", f"{s['iterations']:,}"),
        ("run time (simulated)", f"{fmt(s.get('simulated_time_s'), 's')} s"),
        ("wall time", _seconds(s["wall_time_s"])),
    ]
    if "execution_path" in s:
        rows.append(("execution path", execution_text(s)))
    return rows


SETTINGS_HEAD = ("group", "setting", "value", "unit")


def _seconds(t_s: float) -> str:
    """A duration in s from 1 s on, else in ms."""
    return f"{fmt(t_s, 's')} s" if t_s >= 1.0 else f"{fmt(t_s, 'ms')} ms"


PHASE_HEAD = ("phase", "inside the eye", "steps", "iterations", "max RCM dev. [um]",
              "RMS RCM dev. [um]", "final tip error [um]", "max tracking error [um]",
              "wall [ms]")  # fmt: skip


def phase_rows(s: dict[str, Any]) -> list[list[str]]:
    """One row per phase, the columns of PHASE_HEAD."""
    return [
        [p["name"], "yes" if p["inside_eye"] else "no", f"{p['steps']:,}",
         f"{p['iterations']:,}", fmt(p["max_rcm_deviation_m"], "um"),
         fmt(p["rms_rcm_deviation_m"], "um"), fmt(p["final_tip_error_m"], "um"),
         fmt(p["max_tracking_error_m"], "um"), fmt(p["wall_time_s"], "ms")]
        for p in s["phases"]
    ]  # fmt: skip


def table(head: Sequence[str], rows: Sequence[Sequence[str]], left: int = 1) -> str:
    """An HTML table; the first `left` columns are left-aligned (text), the rest numbers."""

    def cell(tag: str, i: int, v: str) -> str:
        cls = " class='l'" if i < left else ""
        return f"<{tag}{cls}>{html.escape(str(v))}</{tag}>"

    th = "".join(cell("th", i, h) for i, h in enumerate(head))
    body = "".join(
        "<tr>" + "".join(cell("td", i, v) for i, v in enumerate(r)) + "</tr>" for r in rows
    )
    return f"<table><tr>{th}</tr>{body}</table>"


def figure(name: str, path: Path) -> str:
    """An embedded PNG with its caption."""
    data = base64.b64encode(Path(path).read_bytes()).decode()
    caption = CAPTIONS.get(name, name.replace("_", " "))
    return (f"<figure><img alt='{html.escape(name)}' src='data:image/png;base64,{data}'>"
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")  # fmt: skip


def render(result: RunResult, summary: dict[str, Any], figures: dict[str, Path],
           scenario_text: str | None = None) -> str:  # fmt: skip
    """The whole page as a string."""
    s = summary
    title = (f"rcmplan {s['procedure']}: scenario {s['scenario']}, {s['method']} "
             f"on the {s['plant']} plant")  # fmt: skip
    body = [
        f"<h1>{html.escape(title)}</h1>",
        _status(s["status"]),
        _headline(s, result.scenario.eye(result.robot).trocar_radius),
        f"<h2>Phases</h2>{table(PHASE_HEAD, phase_rows(s))}",
        _limits(s),
        "<h2>Figures</h2>" + "".join(figure(n, p) for n, p in figures.items()),
        "<h2>Settings</h2>"
        + table(SETTINGS_HEAD, settings_rows(result.scenario, result.robot), left=4),
    ]
    if scenario_text:
        body.append(f"<h2>Scenario file</h2><pre>{html.escape(scenario_text)}</pre>")
    body.append(
        f"<p><small>rcmplan {html.escape(__version__)}. summary.json holds the same figures "
        "in SI units.</small></p>"
    )
    return (
        '<!doctype html><html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width,initial-scale=1">'
        f"<title>{html.escape(title)}</title><style>{CSS}</style></head><body>\n"
        + "\n".join(body)
        + "\n</body></html>\n"
    )


def _status(status: str) -> str:
    cls = "ok" if status == "ok" else "bad"
    return f"<p class='wrap status-{cls}'><b>status: {html.escape(status)}</b></p>"


def _limits(s: dict[str, Any]) -> str:
    """The limit violations per kind and the limited waypoints (the first listed of all)."""
    if "limit_violations" not in s:
        return ""
    n, rows = s["limited_waypoints"], limited_rows(s)
    worst = f"max waypoint tip error {um(s['max_waypoint_tip_error_m'])}"
    if n == 0:
        limited = f"<p>Every waypoint reached within the loop tolerance's bound ({worst}).</p>"
    else:
        listed = f"the first {len(rows)}" if len(rows) < n else "all"
        limited = (f"<p>Limited waypoints: {n:,}, not reached within the loop tolerance's "
                   f"bound because a limit held the step back ({worst}); {listed} listed:</p>"
                   + table(LIMITED_HEAD, rows, left=2))  # fmt: skip
    return (
        "<h2>Limits and waypoints</h2><p>Records of the whole run that break a limit the QP "
        "holds (the QP holds them at every step; pinv, pinv-thesis and DLS do not, and are "
        "measured against the same limits):</p>"
        + table(VIOLATION_HEAD, violation_rows(s), left=2)
        + limited
    )


def _headline(s: dict[str, Any], trocar_radius_m: float) -> str:
    items = "".join(
        f"<div><dt>{html.escape(k)}</dt><dd>{html.escape(v)}</dd></div>"
        for k, v in headline(s, trocar_radius_m)
    )
    return f'<dl class="head">{items}</dl>'
