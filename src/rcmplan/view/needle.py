"""The needle as the view draws it: a polyline in the robot base frame, [m].

A straight needle is the segment from the logged needle base to the logged tip. A curved needle
is its shaft and arc posed by the robot model at the record's joints (the log holds the shaft's
base and the arc's tip only).
"""

from __future__ import annotations

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.robot.curved import CurvedTipRobot
from rcmplan.robot.model import RobotModel

ARC_POINTS = 16


def needle_polyline(
    robot: RobotModel | None, q: FloatArray, base: FloatArray, tip: FloatArray
) -> FloatArray:
    """Points (k, 3) along the needle from its base to its tip, [m]."""
    if isinstance(robot, CurvedTipRobot) and robot.needle.curved:
        T = robot.base.tool_pose(q)
        t = np.linspace(0.0, robot.needle.arc_angle, ARC_POINTS)
        local = np.array([np.zeros(3), *(robot.needle.arc_local(a) for a in t)])
        return np.asarray(local @ T[:3, :3].T + T[:3, 3])
    return np.array([base, tip], dtype=float)


def segments(points: FloatArray) -> FloatArray:
    """A polyline (k, 3) as k - 1 line segments (k - 1, 2, 3)."""
    return np.stack([points[:-1], points[1:]], axis=1)
