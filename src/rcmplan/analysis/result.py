"""What a run produced: the scenario, its log, the metrics per phase, and the summary.json
contract (`RunResult.summary`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from rcmplan._version import __version__
from rcmplan.analysis.metrics import PhaseMetrics, overall, slider_use
from rcmplan.control.log import RunLog
from rcmplan.exceptions import RcmplanError
from rcmplan.robot.model import RobotModel
from rcmplan.scene.scenario import Scenario

# The statuses of a run that went through every phase: within its bounds ("ok"), or with its
# measured motion beyond one (`analysis.limits.broken_bounds`).
FINISHED = ("ok", "limit_violated")


@dataclass
class RunResult:
    """What a run produced.

    Attributes:
        scenario: The scenario that ran.
        log: The run log (partial when the run stopped early).
        phases: Metrics per phase.
        status: "ok", "limit_violated" (every phase ran, but the measured motion broke a
            bound the run states: `message` names it), "interrupted" (SIGINT, SIGTERM) or the
            `status` of the error that stopped the run ("rcm_bound_exceeded",
            "unreachable_target", "no_convergence", ...).
        message: Why the run stopped, on one line ("" for a finished run).
        error: The exception that stopped the run, if any.
        wall_time_s: Wall time of the whole run (planning, control, measuring) in [s].
        command: The rcmplan command that ran it ("inject", "spiral", "render", "compare"),
            named first in its summary; None for a run from Python.
    """

    scenario: Scenario
    log: RunLog
    phases: list[PhaseMetrics]
    status: str
    wall_time_s: float
    robot: RobotModel
    error: RcmplanError | None = None
    message: str = ""
    extra: dict[str, Any] = field(default_factory=dict)
    command: str | None = None

    @property
    def ok(self) -> bool:
        """True when the run finished every phase within the bounds it states."""
        return self.status == "ok"

    @property
    def finished(self) -> bool:
        """True when the run went through every phase (status "ok" or "limit_violated")."""
        return self.status in FINISHED

    def summary(self) -> dict[str, Any]:
        """The summary.json contract: scenario, method, plant, status, phases, overall figures."""
        phases = [
            {
                "name": p.name,
                "inside_eye": p.inside_eye,
                "max_rcm_deviation_m": p.max_rcm_deviation_m,
                "rms_rcm_deviation_m": p.rms_rcm_deviation_m,
                "max_rcm_deviation_xyz_m": p.max_rcm_deviation_xyz_m,
                "final_tip_error_m": p.final_tip_error_m,
                "max_tracking_error_m": p.max_tracking_error_m,
                "iterations": p.iterations,
                "steps": p.steps,
                "wall_time_s": p.wall_time_s,
            }
            for p in self.phases
        ]
        return {
            **({"command": self.command} if self.command else {}),
            "scenario": self.scenario.name,
            "robot": self.robot.name,
            "needle": self.robot.needle_kind,
            "procedure": self.scenario.procedure,
            "method": self.scenario.method,
            "plant": self.scenario.plant,
            "status": self.status,
            "message": self.message,
            "phases": phases,
            **overall(self.phases),
            "iterations": len(self.log),
            "wall_time_s": self.wall_time_s,
            "sliders": slider_use(self.log, self.robot).as_dict(),
            "rcmplan_version": __version__,
            **self.extra,
        }
