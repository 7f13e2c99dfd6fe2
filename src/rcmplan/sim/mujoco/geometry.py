"""Visual and collision geoms and inertial elements of the iRAM!S MJCF.

Geoms carry no mass (density 0); each moving body gets an explicit `inertial` from the assumed
table in `inertia.py`. Shapes are simple boxes and capsules sized to read well in renders.
"""

from __future__ import annotations

import itertools
import xml.etree.ElementTree as ET

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.robot.curved_needle import arc_point
from rcmplan.sim.mujoco.frames import fmt, quat_from_matrix
from rcmplan.sim.mujoco.inertia import ASSUMED_INERTIA, MM

METAL = "0.75 0.77 0.8 1"
DARK = "0.25 0.27 0.3 1"
STAGE = "0.35 0.55 0.8 1"
NEEDLE = "0.85 0.85 0.9 1"
NEEDLE_RADIUS = 0.3 * MM  # a 23G needle is about 0.6 mm across
SLIDER_OFFSET = 6 * MM  # sliders sit behind the stage along the hinge axis


def add_inertial(body: ET.Element, kind: str, com: FloatArray | None = None) -> None:
    """An `inertial` element from the assumed table; centre of mass at `com` [m] (body frame)."""
    spec = ASSUMED_INERTIA[kind]
    pos = np.zeros(3) if com is None else com
    ET.SubElement(
        body,
        "inertial",
        pos=fmt(pos),
        mass=f"{spec.mass:.17g}",
        diaginertia=fmt(spec.diaginertia()),
    )


def _box(body: ET.Element, cls: str, pos: FloatArray, frame: FloatArray, half: FloatArray,
         rgba: str | None = None) -> None:  # fmt: skip
    attrs = {"class": cls, "type": "box", "pos": fmt(pos), "size": fmt(half)}
    attrs["quat"] = fmt(quat_from_matrix(frame))
    if rgba is not None:
        attrs["rgba"] = rgba
    ET.SubElement(body, "geom", attrs)


def _capsule(body: ET.Element, cls: str, a: FloatArray, b: FloatArray, radius: float,
             rgba: str | None = None) -> None:  # fmt: skip
    attrs = {"class": cls, "type": "capsule", "fromto": fmt(np.concatenate([a, b]))}
    attrs["size"] = f"{radius:.17g}"
    if rgba is not None:
        attrs["rgba"] = rgba
    ET.SubElement(body, "geom", attrs)


def add_pcjm_visuals(
    mount: ET.Element,
    stage: ET.Element,
    hinge: FloatArray,
    e: FloatArray,
    k: FloatArray,
    d: float,
    T_stage_mount: FloatArray,
) -> None:
    """Rails on the mount, a carriage on each slider, the slotted coupler bar on the stage."""
    r = np.cross(e, k)
    M = np.column_stack([e, k, r])  # rail frame in mount coordinates
    for slider, sign in zip(mount.findall("body")[-2:], (1.0, -1.0), strict=True):
        rail = hinge + sign * 0.5 * d * e - 2 * SLIDER_OFFSET * k
        _box(mount, "visual", rail, M, np.array([2, 1, 30]) * MM, DARK)
        _box(slider, "visual", -SLIDER_OFFSET * k, M, np.array([4, 3, 6]) * MM, METAL)
        _box(slider, "collision", -SLIDER_OFFSET * k, M, np.array([4, 3, 6]) * MM)
        _capsule(slider, "visual", -SLIDER_OFFSET * k, np.zeros(3), 1 * MM, DARK)
    R = T_stage_mount[:3, :3]
    h_s = R @ hinge + T_stage_mount[:3, 3]
    M_s = R @ M
    _box(stage, "visual", h_s, M_s, np.array([0.5 * d + 6 * MM, 2 * MM, 3 * MM]), STAGE)
    _box(stage, "collision", h_s, M_s, np.array([0.5 * d + 6 * MM, 2 * MM, 3 * MM]))
    for follower in stage.findall("body"):
        if follower.get("name", "").startswith("follower_"):
            ET.SubElement(
                follower, "geom", {"class": "visual", "type": "sphere", "size": "0.0015"},
                rgba=DARK,
            )  # fmt: skip
    _capsule(stage, "visual", h_s, np.zeros(3), 2 * MM, STAGE)


def add_base_visuals(base: ET.Element, l1: float) -> None:
    """A column carrying the PCJM 1 rails, from the floor to below the rails."""
    height = l1 - 30 * MM
    pos = np.array([0.0, -2 * SLIDER_OFFSET, 0.5 * height])
    half = np.array([25 * MM, 4 * MM, 0.5 * height])
    _box(base, "visual", pos, np.eye(3), half, METAL)
    _box(base, "collision", pos, np.eye(3), half)


ARC_CAPSULES = 12


def add_arc_visuals(needle: ET.Element, radius: float, angle: float) -> None:
    """A curved needle's arc (`rcmplan.robot.curved_needle`) from the shaft's end (the frame's
    origin) bending towards +x, as ARC_CAPSULES capsules, and a site at its tip."""
    pts = [arc_point(radius, 0.0, t) for t in np.linspace(0.0, angle, ARC_CAPSULES + 1)]
    for a, b in itertools.pairwise(pts):
        _capsule(needle, "visual", a, b, NEEDLE_RADIUS, NEEDLE)
    ET.SubElement(needle, "site", name="needle_arc_tip", pos=fmt(pts[-1]))


def add_tool_visuals(holder: ET.Element, needle: ET.Element, l6: float) -> None:
    """The insertion stage block, the roll hub and the needle shaft (sites at base and tip)."""
    base = np.array([0.0, 0.0, -l6])
    _capsule(holder, "visual", base - np.array([0, 0, 25 * MM]), base, 5 * MM, METAL)
    _capsule(holder, "collision", base - np.array([0, 0, 25 * MM]), base, 5 * MM)
    _capsule(needle, "visual", base, base + np.array([0, 0, 6 * MM]), 2 * MM, DARK)
    ET.SubElement(
        needle, "geom", {"class": "visual", "type": "cylinder", "name": "needle"},
        fromto=fmt(np.concatenate([base, np.zeros(3)])), size=f"{NEEDLE_RADIUS:.17g}",
        rgba=NEEDLE,
    )  # fmt: skip
    ET.SubElement(needle, "site", name="needle_base", pos=fmt(base))
    ET.SubElement(needle, "site", name="needle_tip", pos="0 0 0")
    com = np.array([0.0, 0.0, -l6 + 3 * MM])
    add_inertial(needle, "needle", com)
