"""Settings of a teleoperated session, checked before anything is built."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from rcmplan._validate import scalar, vector
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.registry import check_robot
from rcmplan.sim.registry import PLANTS
from rcmplan.teleop.filters import FILTERS, LowPassFilter, NoFilter, TremorFilter
from rcmplan.teleop.fixtures import Fixtures
from rcmplan.teleop.samples import MAX_SPEED_M_S
from rcmplan.teleop.scaling import SCALE_RANGE
from rcmplan.teleop.wflc import WflcFilter

if TYPE_CHECKING:
    from rcmplan.robot.model import RobotModel
    from rcmplan.scene.eye import Eye
    from rcmplan.scene.scenario import Scenario


@dataclass(frozen=True)
class TeleopSettings:
    """A session: robot, plant, pipeline and fixtures (SI units).

    Attributes:
        robot: A robot name (`rcmplan.robot.registry.ROBOTS`) or a robot file (.toml).
        plant: "kinematic", "mujoco" or "mujoco-kinematic".
        scale: Motion scaling in [1, 50]: the tip moves 1/scale of the hand.
        filter: Tremor filter, "none", "lowpass" or "wflc".
        lowpass_hz: Cut-off of the low-pass filter [Hz].
        dt: Control period [s] (1 kHz).
        start_tip: Where the needle tip starts, in the eye frame [m] (origin at the eye
            centre, z along the insertion axis; the default eye's retina has radius 11 mm, so
            (0, 0, 9) mm is 2 mm from it), with the RCM at the trocar.
        fixtures: The virtual fixtures.
        rcm_bound: RCM deviation [m] that stops the session (a safety stop, as
            `LoopSettings.rcm_bound`); violations of the fixtures are counted below it.
        max_input_speed: Fastest master motion [m/s] a replay file may contain.
        stale_after: A live sample older than this [s] counts as released (the needle holds
            when the device stops sending).
    """

    robot: str = "iramis"
    plant: str = "kinematic"
    scale: float = 20.0
    filter: str = "wflc"
    lowpass_hz: float = 2.0
    dt: float = 1e-3
    start_tip: tuple[float, float, float] = (0.0, 0.0, 9e-3)
    fixtures: Fixtures = field(default_factory=Fixtures)
    rcm_bound: float = 45e-6
    max_input_speed: float = MAX_SPEED_M_S
    stale_after: float = 0.1

    def __post_init__(self) -> None:
        check_robot(self.robot)
        if self.plant not in PLANTS:
            raise InvalidInputError("plant", self.plant, f"one of {sorted(PLANTS)}")
        if self.filter not in FILTERS:
            raise InvalidInputError("filter", self.filter, f"one of {FILTERS}")
        scalar("scale", self.scale, *SCALE_RANGE)
        scalar("lowpass_hz", self.lowpass_hz, 0.1, 100.0)
        scalar("dt", self.dt, 1e-4, 1e-2)
        object.__setattr__(self, "start_tip", tuple(vector("start_tip", self.start_tip, 3)))
        scalar("rcm_bound", self.rcm_bound, self.fixtures.rcm_limit, 0.01)
        scalar("max_input_speed", self.max_input_speed, 0.0, 100.0, low_open=True)
        scalar("stale_after", self.stale_after, 0.0, 10.0, low_open=True)

    @property
    def rate_hz(self) -> float:
        """The control rate [Hz]."""
        return 1.0 / self.dt

    def make_filter(self) -> TremorFilter:
        """The tremor filter named by `filter`, at the control rate."""
        if self.filter == "lowpass":
            return LowPassFilter(self.lowpass_hz, 2, self.rate_hz)
        if self.filter == "wflc":
            return WflcFilter(self.rate_hz)
        return NoFilter()


def session_scenario(scenario: str, robot: str | None = None) -> tuple[Scenario, RobotModel, Eye]:
    """The scenario a session runs in (name or file; `robot` in place of its own when given),
    its robot model and its eye. Raises InvalidInputError for a curved needle (a session's
    target is a tip point with the RCM: a straight needle's task) or an eye other than the
    robot's default one (the one `Session` places)."""
    from rcmplan.robot.registry import make_robot
    from rcmplan.scene.eye import default_eye
    from rcmplan.scene.scenario import load_scenario

    sc = load_scenario(scenario)
    if robot:
        sc = sc.with_robot(robot)
    if sc.needle.kind != "straight":
        raise InvalidInputError("scenario needle", sc.needle.kind, "'straight' in a session")
    model = make_robot(sc.robot)
    eye, default = sc.eye(model), default_eye(model)
    if not (np.allclose(eye.center, default.center, rtol=0.0, atol=1e-12)
            and np.allclose(eye.port, default.port, rtol=0.0, atol=1e-12)
            and eye.radius == default.radius and eye.wall == default.wall):  # fmt: skip
        raise InvalidInputError("scenario eye", sc.eye_options,
                                "the robot's default eye in a session")  # fmt: skip
    return sc, model, eye
