"""Figures of a curved-needle injection, read from its log: accuracy at the lateral targets and
the needle's clearance in the trocar port.

Port clearance: the port is the channel through the eye wall, from the trocar point along the
insertion axis to the wall's depth, of radius `trocar_radius`. At each record the needle's
centre line (the shaft and the arc as a polyline of ARC_SEGMENTS chords, whose sagitta is below
1e-8 m for the default arc) is clipped to that slab; its largest distance from the axis is the
port offset, and clearance = trocar radius - offset (the needle's own radius not subtracted).
Distance from a line is convex along a segment, so the clipped ends give each segment's largest.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.control.curved_targets import tip_direction_error
from rcmplan.control.log import RunLog
from rcmplan.robot.curved import CurvedTipRobot
from rcmplan.robot.model import RobotModel
from rcmplan.robot.needle import angle_between
from rcmplan.scene.curved_procedure import plan_lateral
from rcmplan.scene.eye import Eye

ARC_SEGMENTS = 200
OUTSIDE_PHASES = ("approach", "withdraw")  # the needle is not in the port


def arc_points(robot: CurvedTipRobot) -> FloatArray:
    """The arc's ARC_SEGMENTS points after the shaft's end (ARC_SEGMENTS, 3), in the needle base
    frame [m]."""
    ts = np.linspace(0.0, robot.needle.arc_angle, ARC_SEGMENTS + 1)[1:]
    return np.array([robot.needle.arc_local(t) for t in ts])


def needle_polyline(robot: RobotModel, q: FloatArray, arc: FloatArray | None = None) -> FloatArray:
    """The needle's centre line (N, 3) in [m]: base, shaft's end, then the arc if curved
    (`arc`: its points in the needle base frame, `arc_points`, computed if not given)."""
    points = np.array([robot.needle_point(q, 0.0), robot.needle_point(q, 1.0)])
    if isinstance(robot, CurvedTipRobot) and robot.needle.curved:
        T = robot.base.tool_pose(q)
        local = arc_points(robot) if arc is None else arc
        points = np.vstack([points, local @ T[:3, :3].T + T[:3, 3]])
    return points


def port_offset(eye: Eye, polyline: FloatArray) -> FloatArray:
    """Largest distance in [m] from the insertion axis of the needle's points within the wall
    (0 if none is), of one polyline (N, 3) (a 0-d array) or of each of many (R, N, 3) (R,)."""
    polyline = np.asarray(polyline)
    lines = polyline.reshape(-1, *polyline.shape[-2:])
    x = (lines - eye.port) @ eye.axis
    x0, x1 = x[:, :-1], x[:, 1:]
    lo, hi = np.minimum(x0, x1), np.maximum(x0, x1)
    line, seg = np.nonzero((hi >= 0.0) & (lo <= eye.wall))  # the segments within the wall
    worst = np.zeros(lines.shape[0])
    x0, x1, lo, hi = x0[line, seg], x1[line, seg], lo[line, seg], hi[line, seg]
    p0, p1 = lines[line, seg] - eye.port, lines[line, seg + 1] - eye.port
    r0, r1 = p0 - x0[:, None] * eye.axis, p1 - x1[:, None] * eye.axis
    flat = x1 == x0
    span = np.where(flat, 1.0, x1 - x0)
    for xc in (np.maximum(lo, 0.0), np.minimum(hi, eye.wall)):
        t = np.where(flat, 0.0, (xc - x0) / span)
        np.maximum.at(worst, line, np.linalg.norm(r0 + t[:, None] * (r1 - r0), axis=-1))
    return worst.reshape(polyline.shape[:-2])


def needle_polylines(robot: RobotModel, joints: FloatArray,
                     arc: FloatArray | None = None) -> FloatArray:  # fmt: skip
    """`needle_polyline` at each joints row (R, n), (R, N, 3): a curved needle's from its
    kernels' needle frames (`CurvedTipRobot.needle_frames`: the arc's points (x, 0, z) in the
    mount frame at p(0) + x b + z a), another robot's one row at a time."""
    if not isinstance(robot, CurvedTipRobot) or robot.arrays is None:
        return np.array([needle_polyline(robot, q, arc) for q in joints])
    local = arc_points(robot) if arc is None else arc
    F = robot.needle_frames(joints)
    o, a, b = F[:, 0:1], F[:, 2:3], F[:, 3:4]
    curve = o + local[None, :, 0:1] * b + local[None, :, 2:3] * a
    return np.concatenate([F[:, 0:2], curve], axis=1)


def port_offsets(robot: RobotModel, eye: Eye, log: RunLog) -> dict[str, float]:
    """The largest port offset in [m] of each phase in which the needle is in the port."""
    out: dict[str, float] = {}
    arc = arc_points(robot) if isinstance(robot, CurvedTipRobot) and robot.needle.curved else None
    for pid, name in enumerate(log.phase_names):
        rows = np.flatnonzero(log.phase == pid)
        if name in OUTSIDE_PHASES or rows.size == 0:
            continue
        lines = needle_polylines(robot, log.joints[rows], arc)
        out[name] = float(port_offset(eye, lines).max())
    return out


def curved_figures(robot: RobotModel, scenario: Any, eye: Eye, log: RunLog) -> dict[str, Any]:
    """Tip position and direction errors at every lateral target, approach angles to the
    retina normal (curved and the straight needle's from the trocar) and the port clearance."""
    if not isinstance(robot, CurvedTipRobot):
        return {}
    pts = scenario.points(eye).as_dict()
    n = scenario.needle
    tips = [pts[v] for v in scenario.visits]
    planned = plan_lateral(robot, eye, tips, n.directions, n.tolerance)
    rows = []
    for name, target in zip(scenario.visits, planned, strict=True):
        q = log.joints[np.flatnonzero(log.phase == log.phase_names.index(f"p3-{name}"))[-1]]
        normal = (target.x[:3] - eye.center) / np.linalg.norm(target.x[:3] - eye.center)
        line = (target.x[:3] - eye.port) / np.linalg.norm(target.x[:3] - eye.port)
        rows.append({
            "name": name,
            "tip_error_m": float(np.linalg.norm(robot.tip(q) - target.x[:3])),
            "tip_direction_error_rad": tip_direction_error(robot, q, target.direction),
            "requested_direction_deviation_rad": target.deviation,
            "approach_to_normal_rad": angle_between(target.direction, normal),
            "straight_approach_to_normal_rad": angle_between(line, normal),
        })  # fmt: skip
    offsets = port_offsets(robot, eye, log)
    worst = max(offsets.values()) if offsets else 0.0
    return {
        "lateral_targets": rows,
        "max_target_tip_error_m": max(r["tip_error_m"] for r in rows),
        "max_tip_direction_error_rad": max(r["tip_direction_error_rad"] for r in rows),
        "port_offset_m": offsets,
        "worst_port_clearance_m": eye.trocar_radius - worst,
    }
