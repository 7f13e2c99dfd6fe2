"""A robot's state (q, lambda) with the kinematics one control step shares, computed once (as
mink's `Configuration` caches its frames)."""

from __future__ import annotations

from functools import cached_property

from rcmplan._validate import FloatArray, scalar, vector
from rcmplan.control.limits.base import Kinematics, kinematics
from rcmplan.robot.checks import robot_model
from rcmplan.robot.model import RobotModel


class Configuration:
    """Joints q (n,) and the RCM's place lambda in [0, 1] on the needle of `robot`.

    `kinematics` (actuators, the map T, tip and RCM points and Jacobians, the needle axis) is
    computed on first use and kept; tasks (`Objective`) and limits read it. `integrate` gives
    the configuration after a step.
    """

    def __init__(self, robot: RobotModel, q: FloatArray, lam: float) -> None:
        self.robot = robot_model("robot", robot)
        self.q = vector("q", q, len(robot.home)).copy()
        self.lam = scalar("lam", lam, 0.0, 1.0)

    @classmethod
    def known(cls, robot: RobotModel, q: FloatArray, lam: float, kin: Kinematics) -> Configuration:
        """The configuration of a checked state whose kinematics are already computed (the QP
        step's), made without checks."""
        cfg = cls.__new__(cls)
        cfg.robot, cfg.q, cfg.lam = robot, q, lam
        cfg.__dict__["kinematics"] = kin
        return cfg

    @cached_property
    def kinematics(self) -> Kinematics:
        """The step's shared kinematics at (q, lambda)."""
        return kinematics(self.robot, self.q, self.lam)

    def integrate(self, dq: FloatArray, dlam: float) -> Configuration:
        """The configuration after increments dq (m,) of the active joints and dlam."""
        active = list(self.robot.active)
        q = self.q.copy()
        q[active] += vector("dq", dq, len(active))
        return Configuration(self.robot, q, self.lam + scalar("dlam", dlam))

    def __repr__(self) -> str:
        return f"Configuration({self.robot.name!r}, q={self.q.tolist()}, lam={self.lam:g})"
