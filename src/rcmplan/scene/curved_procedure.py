"""The injection with a curved needle: enter through the trocar along the arc, then lateral
targets with the RCM on the shaft (thesis ch. 5).

Entering. A circular arc turned about its own centre slides along its circle, so the point of
the needle at the trocar stays on the circle and keeps the circle's tangent there. The needle is
placed with its tip before the trocar on the circle tangent to the insertion axis at the trocar
(`approach`, a whole-pose motion from home), then turned about the arc's centre until the
shaft's end reaches the trocar (`enter`): the arc passes the port with its tangent on the port
axis throughout, and the shaft then lies on the axis. Inside the port (the wall, from the trocar
to `wall` deeper) the needle then deviates from the axis by the arc's sagitta, about x^2 / (2 R)
at depth x; `rcmplan.scene.clearance` measures it. `insert` pushes the shaft along the axis; the
visits move the tip to each lateral target and back with the RCM at the trocar; `retract` and
`exit` reverse the entry.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rcmplan._validate import FloatArray, scalar
from rcmplan.control.curved_targets import LateralTarget, lateral_target
from rcmplan.control.phase import Phase, interpolate
from rcmplan.exceptions import InvalidInputError, UnreachableTargetError
from rcmplan.robot.curved import CurvedTipRobot
from rcmplan.robot.curved_needle import DEFAULT_ARC_ANGLE, DEFAULT_RADIUS, CurvedNeedle
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel, SerialArm
from rcmplan.robot.needle import roll_from_axes
from rcmplan.scene.eye import Eye, EyePoints
from rcmplan.scene.procedures import Steps, check_inside

# Entering turns the shaft by alpha + lead / R about the trocar; bending up (world +z) keeps
# iRAM!S's sliders within their assumed travel for alpha = 0.25 rad (measured; +-y and -z do not).
ENTRY_BEND = (0.0, 0.0, 1.0)
NEEDLE_KINDS = ("straight", "curved")
ENTRY_LEAD = 0.2e-3  # [m] arc the tip travels on its circle before it reaches the trocar


def pose_target(needle: CurvedNeedle, T: FloatArray) -> FloatArray:
    """The whole-pose target (p_tip, rho, p_base) (7,) of a needle-base pose T (4, 4)."""
    R, o = T[:3, :3], T[:3, 3]
    return np.array([*(R @ needle.tip_local() + o), roll_from_axes(R[:, 2], R[:, 0]), *o])


def turned(T: FloatArray, centre: FloatArray, axis: FloatArray, angle: float) -> FloatArray:
    """T turned by `angle` [rad] about the line through `centre` along unit `axis`."""
    M = np.eye(4)
    from scipy.spatial.transform import Rotation  # only curved runs pay for scipy.spatial

    M[:3, :3] = Rotation.from_rotvec(angle * axis).as_matrix()
    M[:3, 3] = centre - M[:3, :3] @ centre
    out: FloatArray = M @ T
    return out


def pose_path(T0: FloatArray, T1: FloatArray, n: int) -> list[FloatArray]:
    """n poses from T0 (left out) to T1: origin in a straight line, rotation by slerp."""
    from scipy.spatial.transform import Rotation, Slerp

    slerp = Slerp([0.0, 1.0], Rotation.from_matrix([T0[:3, :3], T1[:3, :3]]))
    out = []
    for k in np.arange(1, n + 1) / n:
        T = np.eye(4)
        T[:3, :3] = slerp([k]).as_matrix()[0]
        T[:3, 3] = T0[:3, 3] + k * (T1[:3, 3] - T0[:3, 3])
        out.append(T)
    return out


def entered_pose(needle: CurvedNeedle, eye: Eye, bend: FloatArray) -> FloatArray:
    """The needle-base pose with the shaft on the insertion axis, its end at the trocar, the
    arc bending towards `bend` (made normal to the axis)."""
    z = eye.axis
    x = bend - float(bend @ z) * z
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    T[:3, 3] = eye.port - needle.shaft_length * z
    return T


def arc_turn(needle: CurvedNeedle, T: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(centre, axis) of the arc of a needle at pose T: turning by +angle advances the tip."""
    centre = T[:3, :3] @ np.array([needle.radius, 0.0, needle.shaft_length]) + T[:3, 3]
    return centre, T[:3, 1].copy()


def entry_poses(needle: CurvedNeedle, eye: Eye, bend: FloatArray, steps: Steps) -> list[FloatArray]:
    """Needle-base poses of the entry, from before the trocar to the shaft's end at it: the
    needle turned about its arc's centre in equal steps."""
    T_in = entered_pose(needle, eye, bend)
    centre, axis = arc_turn(needle, T_in)
    turn = needle.arc_angle + ENTRY_LEAD / needle.radius
    T_pre = turned(T_in, centre, axis, -turn)
    n = steps.count(needle.radius * turn, turn)
    return [turned(T_pre, centre, axis, k * turn / n) for k in range(n + 1)]


def approach_phase(robot: CurvedTipRobot, T_pre: FloatArray, steps: Steps) -> Phase:
    """Whole-pose motion from wherever the needle is to the pose before the entry."""

    def plan(q: FloatArray) -> FloatArray:
        from scipy.spatial.transform import Rotation

        T0 = robot.base.tool_pose(q)
        turn0 = np.linalg.norm(Rotation.from_matrix(T_pre[:3, :3] @ T0[:3, :3].T).as_rotvec())
        n = steps.count(float(np.linalg.norm(T_pre[:3, 3] - T0[:3, 3])), float(turn0))
        return np.array([pose_target(robot.needle, T) for T in pose_path(T0, T_pre, n)])

    return Phase("approach", plan, "free")


def arc_sagitta(needle: CurvedNeedle, depth: float) -> float:
    """Largest distance in [m] of the arc from its tangent over `depth` [m] along it: the
    arc's offset from the port axis while it passes a port of that length."""
    R = needle.radius
    along = min(depth, needle.radius * math.sin(needle.arc_angle))
    return R - math.sqrt(R * R - along * along)


def check_arc_passes(needle: CurvedNeedle, eye: Eye) -> None:
    """Raise UnreachableTargetError if the arc leaves the port while it passes the wall."""
    sag = arc_sagitta(needle, eye.wall)
    if sag > eye.trocar_radius:
        R_min = (eye.wall**2 + eye.trocar_radius**2) / (2.0 * eye.trocar_radius)
        raise UnreachableTargetError(
            f"the arc (R = {1e3 * needle.radius:.3g} mm) leaves the axis by {1e3 * sag:.3f} mm "
            f"in the {1e3 * eye.wall:.3g} mm wall; valid: within the trocar radius "
            f"{1e3 * eye.trocar_radius:.3g} mm (R >= {1e3 * R_min:.3g} mm)"
        )


def curved_injection(
    robot: CurvedTipRobot,
    eye: Eye,
    points: EyePoints,
    visits: tuple[str, ...],
    directions: tuple[tuple[float, float, float], ...] | None = None,
    tolerance: float = math.pi,
    steps: Steps | None = None,
) -> list[Phase]:
    """Approach, enter, insert, visit each lateral target and back, retract, exit.

    Args:
        directions: Requested tip directions (unit, world frame), one per visit; default the
            retina's outward normal at each (the least steep approach the needle can take).
        tolerance: Largest accepted angle [rad] between a requested direction and the one the
            needle takes (`rcmplan.control.curved_targets.lateral_target`).
    """
    steps = steps or Steps()
    pts = points.as_dict()
    check_arc_passes(robot.needle, eye)
    planned = plan_lateral(robot, eye, [pts[v] for v in visits], directions, tolerance)
    bend = np.array(ENTRY_BEND)
    poses = entry_poses(robot.needle, eye, bend, steps)
    entry = np.array([pose_target(robot.needle, T) for T in poses])
    phases = [approach_phase(robot, poses[0], steps), Phase("enter", entry[1:], "free")]
    x_in, x_deep = insertion(robot, eye, points.p3, bend)
    n = steps.count(float(np.linalg.norm(x_deep[:3] - x_in[:3])))
    phases.append(Phase("insert", interpolate(x_in, x_deep, n)))
    for name, target in zip(visits, planned, strict=True):
        check_inside(eye, name, target.x[:3])
        phases.append(Phase(f"p3-{name}", rcm_path(x_deep, target.x, steps)))
        phases.append(Phase(f"{name}-p3", rcm_path(target.x, x_deep, steps)))
    phases.append(Phase("retract", interpolate(x_deep, x_in, n)))
    phases.append(Phase("exit", entry[-2::-1], "free"))
    return phases


def insertion(
    robot: CurvedTipRobot, eye: Eye, p3: FloatArray, bend: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """X_c targets with the shaft's end at the trocar and pushed along the axis until the tip
    is as deep as p3 (the roll unchanged)."""
    T_in = entered_pose(robot.needle, eye, bend)
    tip_ahead = robot.needle.tip_local()[2] - robot.needle_length  # tip beyond the shaft's end
    depth = float((p3 - eye.port) @ eye.axis) - tip_ahead
    if depth <= 0.0:
        raise UnreachableTargetError(
            f"p3 lies {1e3 * (depth + tip_ahead):.3f} mm deep; valid: deeper than the arc's "
            f"{1e3 * tip_ahead:.3f} mm beyond the shaft's end",
            p3,
        )
    T_deep = T_in.copy()
    T_deep[:3, 3] += depth * eye.axis
    return _rcm_target(robot, T_in, eye.port), _rcm_target(robot, T_deep, eye.port)


def _rcm_target(robot: CurvedTipRobot, T: FloatArray, trocar: FloatArray) -> FloatArray:
    p = pose_target(robot.needle, T)
    return np.array([*p[:4], *trocar])


def rcm_path(x0: FloatArray, x1: FloatArray, steps: Steps) -> FloatArray:
    """X_c targets from x0 to x1: the tip in a straight line, the roll the short way round."""
    d = x1 - x0
    d[3] = (d[3] + math.pi) % (2.0 * math.pi) - math.pi
    n = steps.count(float(np.linalg.norm(d[:3])), abs(float(d[3])))
    return interpolate(x0, x0 + d, n)


def plan_lateral(
    robot: CurvedTipRobot, eye: Eye, tips: list[FloatArray],
    directions: tuple[tuple[float, float, float], ...] | None, tolerance: float,
) -> list[LateralTarget]:  # fmt: skip
    """The lateral target of each tip point (requested direction: given or the outward normal)."""
    if directions is not None and len(directions) != len(tips):
        raise InvalidInputError("directions", len(directions), f"{len(tips)}, one per visit")
    out = []
    for i, tip in enumerate(tips):
        want = np.asarray(directions[i]) if directions is not None else tip - eye.center
        out.append(lateral_target(robot, tip, want, eye.port, tolerance))
    return out


@dataclass(frozen=True)
class NeedleOptions:
    """The needle of a scenario and its lateral targets.

    Attributes:
        kind: "straight" or "curved".
        radius: Arc radius R in [m]. arc_angle: Arc angle alpha in [rad].
        directions: Requested tip directions (unit, base frame), one per visit; None: the
            retina's outward normal at each visit (the least steep approach).
        tolerance: Largest angle in [rad] between a requested and the planned direction.
    """

    kind: str = "straight"
    radius: float = DEFAULT_RADIUS
    arc_angle: float = DEFAULT_ARC_ANGLE
    directions: tuple[tuple[float, float, float], ...] | None = None
    tolerance: float = math.pi

    def __post_init__(self) -> None:
        if self.kind not in NEEDLE_KINDS:
            raise InvalidInputError("needle kind", self.kind, f"one of {NEEDLE_KINDS}")
        CurvedNeedle(1.0, self.radius, self.arc_angle)  # checks R and alpha
        scalar("lateral tolerance", self.tolerance, 0.0, math.pi, low_open=True)

    def arc(self) -> tuple[float, float] | None:
        """(R [m], alpha [rad]) of a curved needle's arc, None for a straight one."""
        return (self.radius, self.arc_angle) if self.kind == "curved" else None

    def fit(self, robot: RobotModel) -> RobotModel:
        """`robot` holding this needle (a curved needle on the shaft it holds)."""
        if self.kind == "straight" or isinstance(robot, CurvedTipRobot):
            return robot
        if not isinstance(robot, Iramis | SerialArm):
            raise InvalidInputError("robot", robot.name, "iramis or an arm for a curved needle")
        return CurvedTipRobot(robot, CurvedNeedle(robot.needle_length, self.radius,
                                                  self.arc_angle))  # fmt: skip
