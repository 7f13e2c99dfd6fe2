"""What a sweep runs: the sampling region and the motion settings, hashed for checkpoints.

Both are small frozen values of plain numbers, so they pickle cheaply to any worker, hash into a
checkpoint header and print as JSON. SI units throughout: m, rad, s.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Any, Literal

from rcmplan._validate import integer, scalar
from rcmplan._version import __version__
from rcmplan.control.methods import METHODS, MethodSettings
from rcmplan.control.phase import LoopSettings
from rcmplan.control.solvers import Tolerance, check_damping, check_gains
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel
from rcmplan.robot.registry import check_robot, is_robot_file, make_robot
from rcmplan.scene.eye import Eye, default_eye
from rcmplan.scene.procedures import Steps
from rcmplan.scene.scenario import Scenario
from rcmplan.sim.registry import PLANTS

SamplingKind = Literal["grid", "random"]
SAMPLINGS = ("grid", "random")
FORMAT_VERSION = 1
MAX_TARGETS = 1_000_000  # rays one sweep samples at most


@dataclass(frozen=True)
class Region:
    """Retina targets: rays from the trocar within a cone around the insertion axis.

    Attributes:
        max_angle: Half-angle of the cone in [rad], in (0, pi/2).
        n_targets: Number of rays sampled (reachable or not), 1 to MAX_TARGETS.
        sampling: "grid" (deterministic equal-area spiral) or "random" (seeded, uniform on the
            cone's solid angle).
        seed: Seed of the "random" sampling.
        standoff: Distance in [m] the target stays short of the retina along its ray.
    """

    max_angle: float = math.radians(25.0)
    n_targets: int = 1000
    sampling: SamplingKind = "grid"
    seed: int = 0
    standoff: float = 0.0

    def __post_init__(self) -> None:
        scalar("max_angle", self.max_angle, 0.0, 0.5 * math.pi, low_open=True, high_open=True)
        integer("n_targets", self.n_targets, 1, MAX_TARGETS)
        if self.sampling not in SAMPLINGS:
            raise InvalidInputError("sampling", self.sampling, f"one of {SAMPLINGS}")
        scalar("standoff", self.standoff, 0.0, 5e-3)


@dataclass(frozen=True)
class MotionSettings:
    """One target's motion: eye geometry, start point, control method and loop.

    Attributes:
        method: Control method name (rcmplan.control.methods.METHODS).
        K: Diagonal gains of the pseudoinverse methods (x, phi, psi, rcm_x, rcm_y, rcm_z).
        damping: DLS damping in [m].
        tolerance_position, tolerance_angle: Loop tolerances in [m] and [rad].
        step_position, step_angle: Algorithm 2 step sizes in [m] and [rad].
        max_iterations: Iteration cap of Algorithm 1 per step.
        drift_correction: Re-declare the RCM as the needle point closest to the trocar.
        rcm_bound: Largest RCM distance from the trocar in [m]; beyond it a target's run
            ends (`LoopSettings.rcm_bound`; None: unbounded).
        rcm_tolerance: Largest needle-to-trocar distance in [m] one step may leave
            (`LoopSettings.rcm_tolerance`; None: steps as the solver gives them).
        method_options: Method-specific options (`MethodSettings.extra`: a scenario's [qp]
            section, keys with their unit) as (key, value) pairs sorted by key; a dict is
            accepted and stored so.
        dt: Control period in [s].
        eye_radius, eye_wall, trocar_radius: Eye geometry in [m].
        trocar_offset: Trocar relative to the needle tip at home in [m].
        insertion_angles: Needle angles (phi, psi) of the insertion axis in [rad].
        start_depth: Depth of the start point p3 on the insertion axis inside the trocar in [m].
        plant: Plant each target's motion runs on (rcmplan.sim.registry.PLANTS).
        robot: The robot: a name (`rcmplan.robot.registry.ROBOTS`) or a robot file (.toml).
    """

    method: str = "pinv"
    K: tuple[float, ...] = (1.0,) * 6
    damping: float = 1e-4
    tolerance_position: float = 1e-8
    tolerance_angle: float = 1e-8
    step_position: float = 0.2e-3
    step_angle: float = 2e-3
    max_iterations: int = 100
    drift_correction: bool = True
    rcm_bound: float | None = LoopSettings.rcm_bound
    rcm_tolerance: float | None = LoopSettings.rcm_tolerance
    method_options: tuple[tuple[str, Any], ...] = ()
    dt: float = 1e-3
    eye_radius: float = 12e-3
    eye_wall: float = 1e-3
    trocar_radius: float = 0.45e-3
    trocar_offset: tuple[float, float, float] = (-8e-3, 0.0, 0.0)
    insertion_angles: tuple[float, float] = (0.05, 0.12)
    start_depth: float = 8e-3
    plant: str = "kinematic"
    robot: str = "iramis"

    def __post_init__(self) -> None:
        check_robot(self.robot)
        if self.method not in METHODS:
            raise InvalidInputError("method", self.method, f"one of {METHODS}")
        if self.plant not in PLANTS:
            raise InvalidInputError("plant", self.plant, f"one of {sorted(PLANTS)}")
        object.__setattr__(self, "K", tuple(float(k) for k in check_gains(self.K)))
        object.__setattr__(self, "method_options", checked_options(self.method_options))
        check_damping(self.damping)
        self.steps()
        self.loop()
        self.tolerance().checked()
        scalar("dt", self.dt, 0.0, 0.1, low_open=True)
        scalar("start_depth", self.start_depth, 0.0, 2 * self.eye_radius, low_open=True)

    def model(self) -> RobotModel:
        """The robot model (loaded once per process and robot)."""
        return _model(self.robot)

    def eye(self, robot: RobotModel) -> Eye:
        """The eye placed for the robot."""
        return default_eye(
            robot,
            radius=self.eye_radius,
            wall=self.eye_wall,
            trocar_radius=self.trocar_radius,
            trocar_offset=self.trocar_offset,
            insertion_angles=self.insertion_angles,
        )

    def steps(self) -> Steps:
        """Step sizes of Algorithm 2."""
        return Steps(self.step_position, self.step_angle)

    def tolerance(self) -> Tolerance:
        """Loop tolerance."""
        return Tolerance(self.tolerance_position, self.tolerance_angle)

    def loop(self) -> LoopSettings:
        """Loop settings: iteration cap, drift correction, RCM bound and step tolerance."""
        return LoopSettings(self.max_iterations, self.drift_correction,
                            rcm_bound=self.rcm_bound, rcm_tolerance=self.rcm_tolerance)  # fmt: skip

    def method_settings(self) -> MethodSettings:
        """Gains, damping, tolerance and the method's own options for make_solver."""
        return MethodSettings(K=self.K, damping=self.damping, tolerance=self.tolerance(),
                              extra=dict(self.method_options))  # fmt: skip

    @staticmethod
    def from_scenario(scenario: Scenario, **changes: Any) -> MotionSettings:
        """The motion settings of a scenario (its eye, p3 depth, method and controller: gains,
        tolerances, RCM bound and step tolerance, [qp] options); `changes` replace fields."""
        eye, ms = scenario.eye_options, scenario.method_settings
        base = MotionSettings(
            method=scenario.method,
            K=tuple(ms.K),
            damping=ms.damping,
            tolerance_position=ms.tolerance.position,
            tolerance_angle=ms.tolerance.angle,
            step_position=scenario.steps.position,
            step_angle=scenario.steps.angle,
            max_iterations=scenario.loop.max_iterations,
            drift_correction=scenario.loop.drift_correction,
            rcm_bound=scenario.loop.rcm_bound,
            rcm_tolerance=scenario.loop.rcm_tolerance,
            method_options=tuple(ms.extra.items()),
            dt=scenario.dt,
            eye_radius=eye.get("radius", 12e-3),
            eye_wall=eye.get("wall", 1e-3),
            trocar_radius=eye.get("trocar_radius", 0.45e-3),
            trocar_offset=tuple(eye.get("trocar_offset", (-8e-3, 0.0, 0.0))),
            insertion_angles=tuple(eye.get("insertion_angles", (0.05, 0.12))),
            start_depth=scenario.point_options.get("depth", 8e-3),
            plant=scenario.plant,
            robot=scenario.robot,
        )
        return replace(base, **changes)


def checked_options(options: Any) -> tuple[tuple[str, Any], ...]:
    """Method options (a dict or (key, value) pairs) as hashable pairs sorted by key, lists
    as tuples; InvalidInputError naming an option the QP would refuse."""
    from rcmplan.control.qp_backends import check_backend
    from rcmplan.control.qp_limits import QpLimits

    try:
        pairs = dict(options.items() if isinstance(options, dict) else options)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError("method_options", options, "(key, value) pairs or a dict") from exc
    if not all(isinstance(k, str) for k in pairs):
        raise InvalidInputError("method_options", options, "option names as strings")
    if "solver" in pairs:
        check_backend(pairs["solver"])
    QpLimits.from_extra({k: v for k, v in pairs.items() if k != "solver"})
    return tuple(sorted((k, _frozen(v)) for k, v in pairs.items()))


def _frozen(value: Any) -> Any:
    """value with every list (nested too) as a tuple."""
    return tuple(_frozen(v) for v in value) if isinstance(value, list | tuple) else value


@functools.lru_cache(maxsize=4)
def _model(robot: str) -> RobotModel:
    return make_robot(robot)


@dataclass(frozen=True)
class SweepSettings:
    """A whole sweep: where the targets are and how each is reached."""

    region: Region = field(default_factory=Region)
    motion: MotionSettings = field(default_factory=MotionSettings)

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dictionary (tuples as lists)."""
        return {"region": asdict(self.region), "motion": asdict(self.motion)}

    def digest(self) -> str:
        """SHA-256 over the settings, the robot parameters and the format and package versions."""
        return settings_digest(self.as_dict(), self.motion.robot)


def robot_parameters(robot: str = "iramis") -> dict[str, Any]:
    """What defines the robot: iRAM!S's parameters as plain values (sources left out), a robot
    file's SHA-256, or a shipped arm's name (its file ships with this version)."""
    if is_robot_file(robot):
        with open(robot, "rb") as fh:
            return {"file": robot, "sha256": hashlib.sha256(fh.read()).hexdigest()}
    if robot != "iramis":
        return {"name": robot}
    p = Iramis().params
    return {f.name: getattr(p, f.name) for f in fields(p) if f.name != "sources"}


def settings_digest(settings: dict[str, Any], robot: str = "iramis") -> str:
    """SHA-256 (hex) of canonical JSON of the settings, robot, format and rcmplan version."""
    payload = {
        "settings": settings,
        "robot": robot_parameters(robot),
        "format": FORMAT_VERSION,
        "rcmplan": __version__,
    }
    text = json.dumps(payload, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()
