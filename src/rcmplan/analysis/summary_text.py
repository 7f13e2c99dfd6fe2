"""A run's figures as text, read from its summary (`RunResult.summary`): the lines the command
line prints under the phase table and the rows report.html shows, from one place, so the two
name and round every figure alike (`analysis.units.fmt`).

Names, one per quantity (docs/report.md):
- max RCM deviation: the largest |p_rcm - trocar| over the records inside the eye;
- max tip error at the targets: the worst |tip - target| at the end of a phase inside the eye;
- max waypoint tip error: the worst |tip - target| at the end of a waypoint (a control step's
  target), over every phase;
- tracking error (per phase): |tip - target| after every iteration, the iterations a step takes
  to converge included.
"""

from __future__ import annotations

from typing import Any

from rcmplan.analysis.units import fmt

# What each kind of `limit_violations` counts (rcmplan.analysis.limits).
VIOLATION_MEANING = {
    "travel": "an actuator beyond its travel less the QP's travel margin",
    "speed": "an actuator step above its speed x control period",
    "lam": "lambda outside [0, 1]",
    "rcm": "RCM deviation above the QP's RCM tolerance",
    "retina": "the tip within the retina margin and closing in (contacts exempt)",
    "singular": "a singular term of the robot below the QP's singular floor",
}
LIMITED_HEAD = ("phase", "active limits", "step", "tip error [um]")
VIOLATION_HEAD = ("limit", "counted when", "records breaking it")


def um(value: float | None) -> str:
    """A length in [m] as "X um" ("-" when missing)."""
    return fmt(value, "um", with_unit=True) if value is not None else "-"


def violations_text(s: dict[str, Any]) -> str:
    """The kinds of limit broken with their record counts ("speed 804, retina 12"), "none",
    or "-" when the summary has no limit figures."""
    counts = s.get("limit_violations")
    if counts is None:
        return "-"
    return ", ".join(f"{k} {n:,}" for k, n in counts.items() if n) or "none"


def violations_label(s: dict[str, Any]) -> str:
    """What `violations_text` counts: the records beyond the QP's limits, which only the QP
    holds (measured on every method, so pinv's and DLS's counts say what holding them saves)."""
    method = s.get("method")
    held = "" if method in ("qp", None) else f", which {method} does not hold"
    return f"records beyond the QP's limits{held}"


def execution_text(s: dict[str, Any]) -> str:
    """Which code moved the robot: compiled, reference, or the phases that ran compiled."""
    path = str(s.get("execution_path"))
    if path == "mixed":
        compiled = s.get("compiled_phases") or []
        return f"mixed: compiled in {', '.join(compiled) or 'no phase'}, the Python loop elsewhere"
    return {"compiled": "compiled (every phase)",
            "reference": "reference (the Python loop in every phase)"}.get(path, "-")  # fmt: skip


def inside_text(s: dict[str, Any]) -> str:
    """The figures inside the eye, or why there are none."""
    if s["max_rcm_deviation_m"] is None and s["iterations"]:
        return (f"no record inside the eye (stopped before entering it): max tip error at the "
                f"end of a phase {um(s['max_tip_error_m'])}")  # fmt: skip
    return (f"inside the eye: max RCM deviation {um(s['max_rcm_deviation_m'])}, "
            f"max tip error at the targets {um(s['max_tip_error_m'])}")  # fmt: skip


def summary_lines(s: dict[str, Any]) -> list[str]:
    """The lines printed under the phase table."""
    lines = [f"{inside_text(s)}; {s['iterations']:,} iterations, "
             f"wall time {fmt(s['wall_time_s'], 'ms')} ms"]  # fmt: skip
    if "limit_violations" in s:
        lines.append(
            f"every waypoint: max waypoint tip error {um(s['max_waypoint_tip_error_m'])}, "
            f"{s['limited_waypoints']:,} limited; {violations_label(s)}: {violations_text(s)}"
        )
    if "execution_path" in s:
        lines.append(f"execution path: {execution_text(s)}")
    return lines


def violation_rows(s: dict[str, Any]) -> list[list[str]]:
    """One row per kind of limit: its name, what counts, the records breaking it."""
    counts = s.get("limit_violations") or {}
    return [[k, VIOLATION_MEANING.get(k, ""), f"{n:,}"] for k, n in counts.items()]


def limited_rows(s: dict[str, Any]) -> list[list[str]]:
    """One row per listed limited waypoint (summary.json lists the first 20)."""
    return [
        [str(w["phase"]), ", ".join(w["active_limits"]), f"{w['step']:,}",
         fmt(w["tip_error_m"], "um")]
        for w in s.get("limited_waypoint_list", [])
    ]  # fmt: skip
