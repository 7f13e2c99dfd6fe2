"""Generate the iRAM!S MJCF (`robot.xml`) from the `Iramis` DH model: one source of numbers.

Bodies carry the DH frames exactly: `frame1`..`frame6` are T_0^1..T_0^6, each on its joint
(q0 slide, q1 hinge, q2 slide, q3 hinge, q4 = L5 slide, q5 hinge). Each PCJM is a closed loop:
the stage (`frame1` guide slide + `frame2` hinge for PCJM 1) is free in the tree; the two
sliders are separate bodies on slide joints along the rail, spaced d apart across the rail;
two pins (`follower_*`) ride in a slot along the stage line and `connect` equalities tie each
pin to its slider. The stage line then passes through both slider pins, so it turns by
atan((L2 - L1) / d) and its point on the hinge axis moves by (L1 + L2) / 2: eqs. 2.1-2.2
hold exactly, and the needle tip site equals Iramis.forward_kinematics(q(s)).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from rcmplan._validate import FloatArray, scalar
from rcmplan.robot.iramis import SLIDER_NAMES, Iramis
from rcmplan.sim.mujoco.actuators import PiezoParameters
from rcmplan.sim.mujoco.frames import (
    dh_home_transforms,
    fmt,
    inverse,
    joint_in_child,
    pose_attrs,
)
from rcmplan.sim.mujoco.geometry import (
    add_arc_visuals,
    add_base_visuals,
    add_inertial,
    add_pcjm_visuals,
    add_tool_visuals,
)

PCJM_SLIDERS = (("L1", "L2"), ("L3", "L4"))
CONNECTS = ("L1", "L2", "L3", "L4")
ANGLE_MARGIN = math.radians(2.0)


@dataclass(frozen=True)
class ModelOptions:
    """Simulation settings written into the MJCF.

    Attributes:
        physics_dt: Physics timestep in [s].
        gravity_compensation: Cancel gravity on every robot body (MuJoCo `gravcomp`).
        eq_timeconst: Time constant of the loop-closure constraints in [s]; 2 physics steps
            if None (NOTES.md: about 2x the timestep with solimp >= 0.99).
        eq_solimp: Impedance (dmin, dmax, width [m]) of the loop-closure constraints.
        needle_arc: (R [m], alpha [rad]) of a curved needle's arc after the shaft's end, drawn
            as capsules bending towards the tip frame's x axis (visual only), or None.
    """

    physics_dt: float = 1e-4
    gravity_compensation: bool = True
    eq_timeconst: float | None = None
    eq_solimp: tuple[float, float, float] = (0.99, 0.999, 1e-4)
    needle_arc: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        scalar("physics_dt", self.physics_dt, 0.0, 1e-2, low_open=True)

    def timeconst(self) -> float:
        """Loop-closure time constant in [s]."""
        return 2.0 * self.physics_dt if self.eq_timeconst is None else self.eq_timeconst


def robot_xml(
    robot: Iramis, piezo: PiezoParameters | None = None, options: ModelOptions | None = None
) -> str:
    """The robot MJCF as a string (loads on its own; `scene.xml` includes it)."""
    piezo = piezo or PiezoParameters.from_robot(robot)
    options = options or ModelOptions()
    root = ET.Element("mujoco", model="iramis")
    ET.SubElement(root, "compiler", angle="radian", autolimits="true")
    opt = ET.SubElement(
        root, "option", timestep=f"{options.physics_dt:.17g}", integrator="implicitfast"
    )
    # Contacts off: the pins ride inside the stage slots by design and the needle must pass
    # through the trocar; the collision geoms are there for contact studies (enable the flag).
    # Islands off: the robot is one island, so island discovery is pure cost (about 7% of a
    # step, counted with callgrind).
    ET.SubElement(opt, "flag", autoreset="disable", contact="disable", island="disable")
    _defaults(root, options)
    world = ET.SubElement(root, "worldbody")
    base = ET.SubElement(world, "body", name="base", childclass="iramis")
    _chain(base, robot, "1" if options.gravity_compensation else "0", options.needle_arc)
    _equalities(root, options)
    _actuators(root, piezo)
    nq = 14
    ET.SubElement(ET.SubElement(root, "keyframe"), "key", name="home", qpos=fmt(np.zeros(nq)))
    ET.indent(root)
    return ET.tostring(root, encoding="unicode") + "\n"


def _defaults(root: ET.Element, options: ModelOptions) -> None:
    top = ET.SubElement(ET.SubElement(root, "default"), "default", {"class": "iramis"})
    ET.SubElement(top, "joint", armature="1e-6", damping="1e-4")
    ET.SubElement(top, "site", size="0.0005", rgba="1 0 0 1", group="4")
    vis = ET.SubElement(top, "default", {"class": "visual"})
    ET.SubElement(vis, "geom", contype="0", conaffinity="0", group="2", density="0")
    col = ET.SubElement(top, "default", {"class": "collision"})
    ET.SubElement(col, "geom", contype="1", conaffinity="0", group="3", density="0")


def _body(parent: ET.Element, name: str, T: FloatArray, gravcomp: str) -> ET.Element:
    return ET.SubElement(parent, "body", {"name": name, "gravcomp": gravcomp, **pose_attrs(T)})


def _dh_joint(body: ET.Element, name: str, kind: str, T: FloatArray, rng: FloatArray) -> None:
    pos, axis = joint_in_child(T)
    attrs = {"name": name, "type": kind, "pos": fmt(pos), "axis": fmt(axis), "range": fmt(rng)}
    ET.SubElement(body, "joint", attrs)


def _angle_limit(robot: Iramis, a: int, b: int) -> float:
    span = max(robot.upper[b] - robot.lower[a], robot.upper[a] - robot.lower[b])
    return math.atan(span / robot.params.pcjm_spacing) + ANGLE_MARGIN


def _chain(
    base: ET.Element, robot: Iramis, gc: str, arc: tuple[float, float] | None = None
) -> None:
    """The DH frames as nested bodies, the PCJM sliders and pins, the needle.

    `gc` is the MuJoCo `gravcomp` value of every moving body ("1" on, "0" off).
    """
    T = dh_home_transforms(robot)
    add_base_visuals(base, robot.params.l1)
    lo, hi = robot.lower, robot.upper
    travel = max(hi[:4].max(), -lo[:4].min())
    parent, frames = base, []
    for i, (name, kind) in enumerate(
        [("q0", "slide"), ("q1", "hinge"), ("q2", "slide"), ("q3", "hinge")]
    ):
        body = _body(parent, f"frame{i + 1}", T[i], gc)
        limit = _angle_limit(robot, i - 1, i) if kind == "hinge" else travel + 1e-3
        _dh_joint(body, name, kind, T[i], np.array([-limit, limit]))
        add_inertial(body, "guide" if kind == "slide" else f"stage{i // 2 + 1}")
        frames.append(body)
        parent = body
    for k, (a, b) in enumerate(PCJM_SLIDERS):
        mount = base if k == 0 else frames[1]
        _pcjm(mount, frames[2 * k + 1], robot, T[2 * k], T[2 * k + 1], (a, b), gc)
    holder = _body(frames[3], "frame5", T[4], gc)
    _dh_joint(holder, "L5", "slide", T[4], np.array([lo[4] - 1e-3, hi[4] + 1e-3]))
    add_inertial(holder, "holder", np.array([0.0, 0.0, -robot.params.l6]))
    needle = _body(holder, "frame6", T[5], gc)
    _dh_joint(needle, "q5", "hinge", T[5], np.array([lo[5] - 0.01, hi[5] + 0.01]))
    add_tool_visuals(holder, needle, robot.params.l6)
    if arc is not None:
        add_arc_visuals(needle, *arc)


def _pcjm(
    mount: ET.Element,
    stage: ET.Element,
    robot: Iramis,
    T_mount_guide: FloatArray,
    T_guide_stage: FloatArray,
    names: tuple[str, str],
    gc: str,
) -> None:
    """Sliders on `mount` and pins on `stage` for one PCJM; frames in the mount's coordinates.

    Rail r = z of the mount (the prismatic DH axis), hinge axis k = z of the guide frame,
    spacing direction e = k x r: slider a at hinge + e d/2, slider b at hinge - e d/2, so that
    the stage turns by +atan((L_b - L_a) / d) about k (eqs. 2.1-2.2).
    """
    d = robot.params.pcjm_spacing
    hinge = T_mount_guide[:3, 3]
    r = np.array([0.0, 0.0, 1.0])
    k = T_mount_guide[:3, 2]
    e = np.cross(k, r)
    T_stage_mount = inverse(T_mount_guide @ T_guide_stage)
    for name, sign in zip(names, (1.0, -1.0), strict=True):
        pin = hinge + sign * 0.5 * d * e
        slider = ET.SubElement(mount, "body", name=f"slider_{name}", pos=fmt(pin), gravcomp=gc)
        i = SLIDER_NAMES.index(name)
        rng = np.array([robot.lower[i] - 1e-3, robot.upper[i] + 1e-3])
        ET.SubElement(slider, "joint", name=name, type="slide", axis=fmt(r), range=fmt(rng))
        ET.SubElement(slider, "site", name=f"pin_{name}", pos="0 0 0")
        add_inertial(slider, "slider")
        pin_s = T_stage_mount[:3, :3] @ pin + T_stage_mount[:3, 3]
        follower = ET.SubElement(
            stage, "body", name=f"follower_{name}", pos=fmt(pin_s), gravcomp=gc
        )
        axis = T_stage_mount[:3, :3] @ e
        ET.SubElement(follower, "joint", name=f"slot_{name}", type="slide", axis=fmt(axis))
        ET.SubElement(follower, "site", name=f"slot_{name}", pos="0 0 0")
        add_inertial(follower, "follower")
    add_pcjm_visuals(mount, stage, hinge, e, k, d, T_stage_mount)


def _equalities(root: ET.Element, options: ModelOptions) -> None:
    eq = ET.SubElement(root, "equality")
    solref = f"{options.timeconst():.17g} 1"
    solimp = fmt(options.eq_solimp)
    for name in CONNECTS:
        ET.SubElement(
            eq, "connect", name=f"loop_{name}", site1=f"slot_{name}", site2=f"pin_{name}",
            solref=solref, solimp=solimp,
        )  # fmt: skip


def _actuators(root: ET.Element, piezo: PiezoParameters) -> None:
    """Reference servo (integrator state = reference) and velocity feed-forward per slider."""
    act = ET.SubElement(root, "actuator")
    kp, kv, speed = piezo.kp(), piezo.kv(), np.asarray(piezo.speed)
    for i, name in enumerate(SLIDER_NAMES):
        ET.SubElement(
            act, "general", name=f"servo_{name}", joint=name, dyntype="integrator",
            gainprm=f"{kp[i]:.17g}", biastype="affine", biasprm=fmt([0.0, -kp[i], -kv[i]]),
            ctrlrange=fmt([-speed[i], speed[i]]),
            actrange=fmt([piezo.lower[i], piezo.upper[i]]),
        )  # fmt: skip
    for i, name in enumerate(SLIDER_NAMES):
        ET.SubElement(
            act, "general", name=f"feedforward_{name}", joint=name, gainprm=f"{kv[i]:.17g}",
            ctrlrange=fmt([-speed[i], speed[i]]),
        )  # fmt: skip
