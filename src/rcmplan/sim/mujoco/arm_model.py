"""The MuJoCo model of a `SerialArm`, built with `mujoco.MjSpec` from its `JointChain`.

One source of numbers: body k carries chain frame k (pose = joint k's `origin` in body k-1,
joint at the body origin about/along `axis`), so MuJoCo's frames equal `chain.frames(q)` for
every q; the `base` body holds the chain's world placement. The needle is a capsule on the last
body (pose `chain.tip @ needle.mount`) with sites `needle_base` (lambda = 0) and `needle_tip`.

Masses: the shipped arms (`robot.library`) take each link's inertial from their URDF, compiled
by MuJoCo's own URDF import with every <visual> and <collision> element removed (no meshes at
all: the physics needs none, and MuJoCo cannot read the .dae visuals); links fused by MuJoCo
into a moving link come with it, bodies off the chain (Panda's fingers) are dropped. Any other
arm (DH, MJCF) gets `DEFAULT_LINK` on every body. Every body carries `gravcomp` 1. The needle's
own mass (some 30 mg of steel) is left out: each body's inertial is stated explicitly.

Actuators per joint, both fed the reference velocity v [rad/s or m/s] of the period:
`servo_<joint>` (intvelocity: its state is the reference r, integrated from v and clamped to
the joint's travel, force kp (r - q)) and `feedforward_<joint>` (velocity: kv (v - q_dot)).
Together kp (r - q) + kv (v - q_dot): a ramp is tracked without lag (see `ServoOptions`).
"""

from __future__ import annotations

import itertools
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rcmplan._validate import FloatArray, scalar
from rcmplan.exceptions import MissingExtraError
from rcmplan.robot.curved_needle import arc_point
from rcmplan.robot.model import SerialArm
from rcmplan.sim.mujoco.files import mujoco_module
from rcmplan.sim.mujoco.frames import quat_from_matrix
from rcmplan.sim.mujoco.geometry import ARC_CAPSULES
from rcmplan.sim.mujoco.scene import (
    CLOSEUP_FOVY,
    CLOSEUP_OFFSET,
    OFFSCREEN,
    TROCAR_RADIUS,
    EyePhantom,
    camera_axes,
)

NEEDLE_RADIUS = 0.15e-3  # [m], a 30 G needle (0.31 mm outer diameter)
OVERVIEW_FOVY = 45.0  # [deg]
DEFAULT_LINK = (1.0, 1e-2)  # (mass [kg], principal inertia [kg m^2]) of a link without a URDF


@dataclass(frozen=True)
class ServoOptions:
    """Joint servo and simulation settings (assumed values; no arm data sheet gives them).

    Gains per joint are scaled by its effective inertia I_j (the diagonal of MuJoCo's joint-space
    inertia at home, armature included): kp = I_j w^2 [N m/rad or N/m], kv = 2 zeta I_j w
    [N m s/rad or N s/m], w = 2 pi bandwidth. Every joint then has the same normalised response,
    so lagging joints lag in proportion and the needle stays near its line (synchronised
    motion). The bandwidth is high because the RCM target is 10 um at a lever of about 0.5 m:
    at 1 kHz a critically damped servo that follows a ramp lags by w dt exp(-w dt), about 1%
    of a 1 ms period's step, at the end of the period (less in the discrete integrator).
    It is capped at w physics_dt <= 1, since the stiffness term is integrated explicitly
    (implicitfast treats only the velocity terms, kv and damping, implicitly).

    Attributes:
        physics_dt: Physics timestep in [s].
        bandwidth: Servo natural frequency in [Hz].
        damping_ratio: Servo damping ratio (1: critical).
        armature: Reflected rotor inertia of each joint in [kg m^2] ([kg] if prismatic):
            a gear ratio of about 100 on a 1e-5 kg m^2 rotor; it also weakens the coupling
            between joints, which keeps the lags in proportion.
        gravity_compensation: Cancel gravity on every body (MuJoCo `gravcomp`).
    """

    physics_dt: float = 1e-4
    bandwidth: float = 1000.0
    damping_ratio: float = 1.0
    armature: float = 0.1
    gravity_compensation: bool = True

    def __post_init__(self) -> None:
        scalar("physics_dt", self.physics_dt, 0.0, 1e-2, low_open=True)
        scalar("bandwidth", self.bandwidth, 0.0, 0.5 / (math.pi * self.physics_dt), low_open=True)
        scalar("damping_ratio", self.damping_ratio, 0.0, 10.0, low_open=True)
        scalar("armature", self.armature, 0.0, 1e3)

    def gains(self, inertia: FloatArray) -> tuple[FloatArray, FloatArray]:
        """(kp, kv) per joint for effective inertias (n,) in [kg m^2] or [kg]."""
        w = 2.0 * math.pi * self.bandwidth
        return inertia * w * w, 2.0 * self.damping_ratio * inertia * w


def arm_spec(
    arm: SerialArm, options: ServoOptions | None = None, eye: EyePhantom | None = None,
    scenery: bool = False, needle_arc: tuple[float, float] | None = None,
) -> Any:  # fmt: skip
    """The arm's `mujoco.MjSpec` with servos and a `home` keyframe (and the eye, if given);
    with `scenery` (and an eye) what a camera needs too (`_scenery`): links, floor, light and
    the cameras `closeup` and `overview`, and a curved needle's arc (R [m], alpha [rad]) after
    the shaft's end if given (`_arc`)."""
    mj = mujoco_module()
    options = options or ServoOptions()
    spec = mj.MjSpec()
    spec.modelname = arm.name
    spec.compiler.degree = False  # joint ranges in [rad]
    spec.option.timestep = options.physics_dt
    spec.option.integrator = mj.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.disableflags |= int(mj.mjtDisableBit.mjDSBL_CONTACT)  # the needle enters the eye
    last = _chain(spec, arm, options, _link_inertials(arm))
    _needle(mj, last, arm)
    if eye is not None:
        _eye(mj, spec, eye)
        if scenery:
            _scenery(mj, spec, arm, eye)
            if needle_arc is not None:
                _arc(mj, last, arm, *needle_arc)
    _servos(mj, spec, arm, options)
    key = spec.add_key()
    key.name, key.qpos, key.act = "home", arm.home.tolist(), arm.home.tolist()
    return spec


def arm_model(
    arm: SerialArm, options: ServoOptions | None = None, eye: EyePhantom | None = None,
    scenery: bool = False, needle_arc: tuple[float, float] | None = None,
) -> Any:  # fmt: skip
    """The compiled `mujoco.MjModel` of `arm_spec`."""
    return arm_spec(arm, options, eye, scenery, needle_arc).compile()


def arm_xml(arm: SerialArm, options: ServoOptions | None = None) -> str:
    """The arm's MJCF as a string (loads on its own)."""
    return str(arm_spec(arm, options).to_xml())


def _pose(element: Any, T: FloatArray) -> None:
    element.pos = T[:3, 3].tolist()
    element.quat = quat_from_matrix(T[:3, :3]).tolist()


def _chain(spec: Any, arm: SerialArm, options: ServoOptions, inertials: list[Any]) -> Any:
    """Bodies and joints from the chain; returns the last body."""
    mj = mujoco_module()
    parent = spec.worldbody.add_body(name="base")
    _pose(parent, arm.chain.base)
    gc = 1.0 if options.gravity_compensation else 0.0
    for k, joint in enumerate(arm.chain.joints):
        body = parent.add_body(name=f"link_{joint.name}", gravcomp=gc)
        _pose(body, joint.origin)
        mass, ipos, iquat, inertia = inertials[k]
        body.mass, body.ipos, body.iquat, body.inertia = mass, ipos, iquat, inertia
        kind = mj.mjtJoint.mjJNT_SLIDE if joint.kind == "prismatic" else mj.mjtJoint.mjJNT_HINGE
        body.add_joint(
            name=joint.name, type=kind, axis=joint.axis.tolist(), armature=options.armature,
            range=[joint.lower, joint.upper],
        )  # fmt: skip
        parent = body
    return parent


def _link_inertials(arm: SerialArm) -> list[Any]:
    """(mass, ipos, iquat, inertia) per chain body: from the URDF of a shipped arm whose joint
    names match, else `DEFAULT_LINK`."""
    mass, inertia = DEFAULT_LINK
    default = [(mass, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [inertia] * 3)] * arm.chain.n
    path = _urdf_path(arm)
    if path is None:
        return default
    mj = mujoco_module()
    root = ET.parse(path).getroot()
    for link in root.iter("link"):
        for element in [c for c in link if c.tag in ("visual", "collision")]:
            link.remove(element)
    model = mj.MjModel.from_xml_string(ET.tostring(root, encoding="unicode"))
    out = []
    for name in arm.chain.joint_names:
        j = int(mj.mj_name2id(model, mj.mjtObj.mjOBJ_JOINT, name))
        if j < 0:
            return default
        b = int(model.jnt_bodyid[j])
        out.append((float(model.body_mass[b]), model.body_ipos[b].tolist(),
                    model.body_iquat[b].tolist(), model.body_inertia[b].tolist()))  # fmt: skip
    return out


def _urdf_path(arm: SerialArm) -> Path | None:
    """The URDF of a shipped arm of the same name, or None (another arm, or not installed)."""
    from rcmplan.robot.library import ROBOT_FILES
    from rcmplan.robot.shipped import robot_file

    if arm.name not in ROBOT_FILES:
        return None
    try:
        return robot_file(arm.name)
    except MissingExtraError:
        return None


def _needle(mj: Any, body: Any, arm: SerialArm) -> None:
    """The needle capsule and its two sites on the last body, frame chain.tip @ mount."""
    T = arm.chain.tip @ arm.needle.mount
    base = T[:3, 3]
    tip = base + arm.needle.length * T[:3, 2]
    quat = quat_from_matrix(T[:3, :3]).tolist()
    body.add_geom(
        name="needle", type=mj.mjtGeom.mjGEOM_CAPSULE, fromto=[*base, *tip],
        size=[NEEDLE_RADIUS, 0.0, 0.0], rgba=[0.75, 0.75, 0.8, 1.0],
    )  # fmt: skip
    for name, p in (("needle_base", base), ("needle_tip", tip)):
        body.add_site(name=name, pos=p.tolist(), quat=quat, size=[2e-4, 0.0, 0.0], group=4)


def _arc(mj: Any, body: Any, arm: SerialArm, radius: float, angle: float) -> None:
    """A curved needle's arc (`rcmplan.robot.curved_needle`) from the shaft's end, bending
    towards the mount's x, as ARC_CAPSULES capsules on the last body, and the site
    `needle_arc_tip` at its tip."""
    T = arm.chain.tip @ arm.needle.mount
    t = np.linspace(0.0, angle, ARC_CAPSULES + 1)
    local = np.array([arc_point(radius, arm.needle.length, x) for x in t])
    pts = local @ T[:3, :3].T + T[:3, 3]
    for a, b in itertools.pairwise(pts):
        body.add_geom(type=mj.mjtGeom.mjGEOM_CAPSULE, fromto=[*a, *b],
                      size=[NEEDLE_RADIUS, 0.0, 0.0], rgba=[0.75, 0.75, 0.8, 1.0], contype=0,
                      conaffinity=0, density=0.0)  # fmt: skip
    body.add_site(name="needle_arc_tip", pos=pts[-1].tolist(), size=[2e-4, 0.0, 0.0], group=4)


def _eye(mj: Any, spec: Any, eye: EyePhantom) -> None:
    """The eye phantom: a sphere without contacts, the trocar and target sites (world)."""
    body = spec.worldbody.add_body(name="eye", pos=eye.centre.tolist())
    body.add_geom(
        name="eyeball", type=mj.mjtGeom.mjGEOM_SPHERE, size=[eye.radius, 0.0, 0.0],
        rgba=[0.95, 0.93, 0.88, 0.3], contype=0, conaffinity=0, group=1, density=0.0,
    )  # fmt: skip
    body.add_site(name="trocar", pos=(eye.trocar - eye.centre).tolist(),
                  size=[TROCAR_RADIUS, 0.0, 0.0], rgba=[0.1, 0.8, 0.2, 1.0], group=1)  # fmt: skip
    for i, p in enumerate(eye.targets):
        body.add_site(name=f"target_{i}", pos=(p - eye.centre).tolist(), size=[3e-4, 0.0, 0.0],
                      rgba=[0.9, 0.2, 0.2, 1.0], group=1)  # fmt: skip


def _scenery(mj: Any, spec: Any, arm: SerialArm, eye: EyePhantom) -> None:
    """What a camera needs and the physics does not: the links drawn as capsules from each
    joint's origin to the next one's (and to the flange), massless and without contacts, a
    floor at the base, a light, and two cameras as iRAM!S's scene has them: `closeup` on the
    needle tip and the trocar at home, `overview` framing the arm at home and the eye."""
    radius = 0.03 * min(arm.reach, 1.0)  # [m]: 30 mm on an arm reaching 1 m or more
    grey = [0.62, 0.64, 0.68, 1.0]
    bodies = [spec.body("base"), *(spec.body(f"link_{j.name}") for j in arm.chain.joints)]
    ends = [j.origin[:3, 3] for j in arm.chain.joints] + [arm.chain.tip[:3, 3]]
    for body, end in zip(bodies, ends, strict=True):
        body.add_geom(type=mj.mjtGeom.mjGEOM_SPHERE, size=[1.2 * radius, 0.0, 0.0], rgba=grey,
                      contype=0, conaffinity=0, density=0.0, group=2)  # fmt: skip
        if np.linalg.norm(end) > 1e-6:
            body.add_geom(type=mj.mjtGeom.mjGEOM_CAPSULE, fromto=[0.0, 0.0, 0.0, *end],
                          size=[radius, 0.0, 0.0], rgba=grey, contype=0, conaffinity=0,
                          density=0.0, group=2)  # fmt: skip
    frames = arm.chain.frames(arm.home)  # (n + 1, 4, 4): the joints' frames, the flange's
    points = np.vstack([arm.chain.base[:3, 3], frames[:, :3, 3], eye.centre])
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    extent = float(np.linalg.norm(points - centre, axis=1).max())
    base_z = float(arm.chain.base[2, 3])
    spec.add_texture(name="sky", type=mj.mjtTexture.mjTEXTURE_SKYBOX,
                     builtin=mj.mjtBuiltin.mjBUILTIN_GRADIENT, rgb1=[0.35, 0.45, 0.55],
                     rgb2=[0.05, 0.05, 0.08], width=64, height=384)  # fmt: skip
    spec.add_texture(name="grid", type=mj.mjtTexture.mjTEXTURE_2D,
                     builtin=mj.mjtBuiltin.mjBUILTIN_CHECKER, rgb1=[0.2, 0.22, 0.25],
                     rgb2=[0.15, 0.16, 0.18], width=64, height=64)  # fmt: skip
    grid = spec.add_material(name="grid", texrepeat=[20.0, 20.0])
    grid.textures[mj.mjtTextureRole.mjTEXROLE_RGB] = "grid"
    spec.worldbody.add_geom(
        name="floor", type=mj.mjtGeom.mjGEOM_PLANE, size=[2.0 * extent, 2.0 * extent, 0.01],
        pos=[centre[0], centre[1], base_z - 0.002], material="grid", contype=0, conaffinity=0,
    )  # fmt: skip
    spec.worldbody.add_light(pos=[centre[0], centre[1], base_z + 3.0 * extent], dir=[0, 0, -1],
                             castshadow=False)  # fmt: skip
    spec.visual.global_.offwidth, spec.visual.global_.offheight = OFFSCREEN
    spec.visual.headlight.diffuse, spec.visual.headlight.ambient = [0.5] * 3, [0.3] * 3
    tip = arm.tip(arm.home)
    mid = 0.5 * (tip + eye.trocar)
    direction = np.array([0.12, -0.25, 0.17])  # iRAM!S's overview, seen from the same side
    distance = 1.15 * extent / math.sin(math.radians(OVERVIEW_FOVY / 2.0))
    direction *= distance / np.linalg.norm(direction)
    sight = _LinkSight(mj, spec, arm)
    for name, offset, target, fovy, seen in (
        ("overview", direction, centre, OVERVIEW_FOVY, (eye.centre, tip)),
        ("closeup", CLOSEUP_OFFSET, mid, CLOSEUP_FOVY, (tip, eye.trocar)),
    ):
        pos = sight.clear_view(target, offset, seen)
        camera = spec.worldbody.add_camera(name=name, pos=pos.tolist(), fovy=fovy)
        camera.quat = quat_from_matrix(camera_axes(pos, target)).tolist()


class _LinkSight:
    """The links drawn at home (the capsules of `_scenery`, geom group 2), for MuJoCo's ray
    casts (`mj_ray`): which camera places see the needle and the eye past them."""

    AZIMUTHS = np.radians([0.0, 45.0, -45.0, 90.0, -90.0, 135.0, -135.0, 180.0])

    def __init__(self, mj: Any, spec: Any, arm: SerialArm) -> None:
        self.mj, self.model = mj, spec.compile()
        self.data = mj.MjData(self.model)
        self.data.qpos[:] = arm.home
        mj.mj_kinematics(self.model, self.data)
        self.links = np.array([0, 0, 1, 0, 0, 0], dtype=np.uint8)  # geom group 2 only

    def blocked(self, pos: FloatArray, point: FloatArray) -> bool:
        """True if a link lies on the segment from pos to point."""
        geom = np.array([-1], dtype=np.int32)
        x = self.mj.mj_ray(self.model, self.data, pos, point - pos, self.links, 1, -1, geom)
        return bool(0.0 <= x < 1.0)

    def clear_view(self, target: FloatArray, offset: FloatArray, seen: tuple) -> FloatArray:
        """target + offset turned about the vertical by the first of `AZIMUTHS` from which no
        link hides a point of `seen` (the unturned place if every one is hidden)."""
        for a in self.AZIMUTHS:
            c, s = math.cos(a), math.sin(a)
            pos = target + np.array([c * offset[0] - s * offset[1], s * offset[0] + c * offset[1],
                                     offset[2]])  # fmt: skip
            if not any(self.blocked(pos, p) for p in seen):
                return pos
        return target + offset


def _servos(mj: Any, spec: Any, arm: SerialArm, options: ServoOptions) -> None:
    """Servo and feed-forward actuators, gains scaled by the inertia at home (ServoOptions)."""
    model = spec.compile()
    data = mj.MjData(model)
    data.qpos[:] = arm.home
    mj.mj_forward(model, data)
    M = np.zeros((model.nv, model.nv))
    mj.mj_fullM(model, data, M)
    inertia = np.diag(M).copy()  # armature included
    kp, kv = options.gains(inertia)
    speed = arm.speed
    for j, joint in enumerate(arm.chain.joints):
        servo = spec.add_actuator(name=f"servo_{joint.name}", target=joint.name)
        servo.trntype = mj.mjtTrn.mjTRN_JOINT
        servo.set_to_intvelocity(kp=float(kp[j]), kv=0.0)
        servo.actlimited, servo.actrange = True, [joint.lower, joint.upper]
        ff = spec.add_actuator(name=f"feedforward_{joint.name}", target=joint.name)
        ff.trntype = mj.mjtTrn.mjTRN_JOINT
        ff.set_to_velocity(kv=float(kv[j]))
        for act in (servo, ff):
            act.ctrllimited, act.ctrlrange = True, [-speed[j], speed[j]]
