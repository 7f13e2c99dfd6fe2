"""The eye: a sphere with a trocar on its wall, and the named points of the thesis's fig. 3.2.

Geometry queries only; procedures live in `procedures.py`. All points in the robot base frame
in [m].

Default placement (documented, not from the thesis, which gives no eye pose): the trocar lies
8 mm in front of the needle tip at home (the needle points along -x at home); the insertion axis
is the needle axis with needle angles (phi, psi) = (0.05, 0.12) rad, so that aligning the needle
with the trocar changes both angles; the eye
centre lies on the insertion axis one radius inside the trocar.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rcmplan._validate import (
    F64,
    WORKSPACE_M,
    FloatArray,
    instance,
    scalar,
    vector,
    workspace_point,
)
from rcmplan.control.limits.rows import radial_gap
from rcmplan.exceptions import InvalidInputError, UnreachableTargetError
from rcmplan.robot.checks import robot_model
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel
from rcmplan.robot.needle import axis_from_angles

POINT_NAMES = ("p1", "p2", "p3", "p4", "p5", "p6", "p7")
INSERTION_ANGLE = 1.2  # |insertion angles| in [rad] (the scenario schema's insertion_angles_rad)


@dataclass(frozen=True)
class Eye:
    """A spherical eye with one trocar.

    Attributes:
        center: Eye centre (3,) in [m].
        radius: Outer (scleral) radius in [m]; about 12 mm for an adult eye.
        wall: Wall thickness in [m]; the retina is the inner sphere of radius `radius - wall`.
        trocar: Trocar point (3,) on the outer sphere in [m].
        trocar_radius: Radius of the trocar port in [m] (0.45 mm in the thesis).
    """

    center: FloatArray
    radius: float = 12e-3
    wall: float = 1e-3
    trocar: FloatArray | None = None
    trocar_radius: float = 0.45e-3

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", workspace_point("eye.center", self.center))
        radius = scalar("eye.radius", self.radius, 0.0, 0.05, low_open=True)
        object.__setattr__(self, "radius", radius)
        object.__setattr__(self, "wall", scalar("eye.wall", self.wall, 0.0, radius, high_open=True))
        trocar_radius = scalar("eye.trocar_radius", self.trocar_radius, 0.0, 5e-3, low_open=True)
        object.__setattr__(self, "trocar_radius", trocar_radius)
        if self.trocar is None:
            raise InvalidInputError("eye.trocar", None, "a point (3,) on the eye's outer sphere")
        trocar = workspace_point("eye.trocar", self.trocar)
        off = abs(float(np.linalg.norm(trocar - self.center)) - self.radius)
        if off > 1e-6:
            raise InvalidInputError(
                "eye.trocar",
                trocar.tolist(),
                f"a point on the outer sphere (it is {off:.3g} m off)",
            )
        object.__setattr__(self, "trocar", trocar)

    @property
    def retina_radius(self) -> float:
        """Radius of the inner (retinal) surface in [m]."""
        return self.radius - self.wall

    @property
    def port(self) -> FloatArray:
        """The trocar point (3,)."""
        assert self.trocar is not None  # set in __post_init__
        return self.trocar

    @property
    def axis(self) -> FloatArray:
        """Insertion axis: unit vector from the trocar to the eye centre."""
        d = self.center - self.port
        return d / np.linalg.norm(d)

    def distance_to_retina(self, p: FloatArray) -> float:
        """Signed distance in [m] from p (3,) to the retina: positive inside the vitreous."""
        if p.__class__ is not np.ndarray or p.dtype is not F64 or p.shape != (3,):
            p = vector("p", p, 3)
        d = radial_gap(self.center, self.retina_radius, p)
        if not math.isfinite(d):
            vector("p", p, 3)  # names the non-finite entry
        return d

    def retina_point(self, direction: FloatArray) -> FloatArray:
        """Where the ray from the trocar along `direction` (non-zero) meets the retina."""
        d = vector("direction", direction, 3)
        norm = float(np.linalg.norm(d))
        if not 1e-12 < norm < 1e150:
            raise InvalidInputError("direction", direction, "a non-zero direction (3,)")
        d = d / norm
        m = self.port - self.center
        b = float(np.dot(m, d))
        c = float(np.dot(m, m)) - self.retina_radius**2
        disc = b * b - c
        if disc < 0:
            raise UnreachableTargetError(f"the ray along {d.tolist()} misses the retina")
        return self.port + (-b + math.sqrt(disc)) * d


def eye_frame(eye: Eye) -> FloatArray:
    """Rotation (3, 3) whose columns are the eye frame's x, y, z in the base frame: z along the
    insertion axis (trocar to centre), x = z x z_base / |z x z_base| (horizontal in the base
    frame), y = z x x. Points in this frame have their origin at the eye centre."""
    z = eye.axis
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def from_eye_frame(eye: Eye, points_eye: FloatArray) -> FloatArray:
    """Points (N, 3) or (3,) in [m] in the eye frame (`eye_frame`, origin at the centre) -> the
    same in the robot base frame [m]."""
    return eye.center + np.asarray(points_eye, dtype=float) @ eye_frame(eye).T


def default_eye(
    robot: RobotModel | None = None,
    radius: float = 12e-3,
    wall: float = 1e-3,
    trocar_radius: float = 0.45e-3,
    trocar_offset: tuple[float, float, float] = (-8e-3, 0.0, 0.0),
    insertion_angles: tuple[float, float] = (0.05, 0.12),
) -> Eye:
    """An eye placed for a robot (see module docstring for the defaults).

    Args:
        radius: Outer radius in [m].
        wall: Wall thickness in [m].
        trocar_radius: Trocar port radius in [m].
        trocar_offset: Trocar point relative to the needle's (shaft's) end at home, in [m].
        insertion_angles: Needle angles (phi, psi) in [rad] of the insertion axis; the eye
            centre lies on it one radius inside the trocar.
    """
    robot = Iramis() if robot is None else robot_model("robot", robot)
    offset = vector("trocar_offset", trocar_offset, 3)
    if np.abs(offset).max() > WORKSPACE_M:
        raise InvalidInputError("trocar_offset", offset, f"within +-{WORKSPACE_M:g} m per axis")
    phi, psi = vector("insertion_angles", insertion_angles, 2)
    if max(abs(phi), abs(psi)) > INSERTION_ANGLE:
        valid = f"angles within +-{INSERTION_ANGLE:g} rad"
        raise InvalidInputError("insertion_angles", insertion_angles, valid)
    radius = scalar("eye.radius", radius, 0.0, 0.05, low_open=True)
    trocar = robot.needle_point(robot.home, 1.0) + offset
    axis = axis_from_angles(phi, psi)
    return Eye(
        center=trocar + radius * axis,
        radius=radius,
        wall=wall,
        trocar=trocar,
        trocar_radius=trocar_radius,
    )


@dataclass(frozen=True)
class EyePoints:
    """The seven points of fig. 3.2, each (3,) in [m].

    p1 on the trocar axis outside the eye, p2 the trocar, p3 in the vitreous on the axis,
    p4..p7 on the retina.
    """

    p1: FloatArray
    p2: FloatArray
    p3: FloatArray
    p4: FloatArray
    p5: FloatArray
    p6: FloatArray
    p7: FloatArray

    def as_dict(self) -> dict[str, FloatArray]:
        """Name -> point."""
        return {n: getattr(self, n) for n in POINT_NAMES}


def default_points(
    eye: Eye, outside: float = 5e-3, depth: float = 8e-3, spread: float = 0.12
) -> EyePoints:
    """Points of fig. 3.2 for an eye.

    Args:
        outside: Distance of p1 outside the trocar along the axis in [m], in (0, 0.1].
        depth: Depth of p3 inside the trocar along the axis in [m], in (0, 2 eye.radius].
        spread: Angle in [rad] between the axis and the rays from the trocar to p4..p7; p4/p5
            tilt phi by +-spread and p6/p7 tilt psi by +-spread, so both needle angles change;
            in [0, pi/2).
    """
    from rcmplan.robot.needle import angles_from_axis

    instance("eye", eye, Eye, "an Eye (default_eye(robot))")
    scalar("outside", outside, 0.0, 0.1, low_open=True)
    scalar("depth", depth, 0.0, 2.0 * eye.radius, low_open=True)
    scalar("spread", spread, 0.0, 0.5 * math.pi, high_open=True)

    phi, psi = angles_from_axis(eye.axis)
    rays = [(phi + spread, psi), (phi - spread, psi), (phi, psi + spread), (phi, psi - spread)]
    retina = [eye.retina_point(axis_from_angles(a, b)) for a, b in rays]
    return EyePoints(eye.port - outside * eye.axis, eye.port, eye.port + depth * eye.axis, *retina)
