"""Generated inputs to the public API, `import rcmplan as rp` (tests/api_inputs.py has the rule):
every call raises a typed rcmplan error naming the argument or returns a finite result within
its documented bounds; never a generic Python error, never a silent NaN.

This file: the robot methods users call, on iRAM!S and on the shipped UR5. The other
test_api_properties_*.py files cover the constructors, loaders, control, plants and scene.
`test_every_export_is_probed` checks that together they call every exported name.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import rcmplan as rp

from api_inputs import (
    Arg,
    examples,
    finite,
    number,
    one_bad,
    optional,
    probe,
    shaped,
    vector,
    vectors,
)

IRAMIS = rp.Iramis()
UR5 = rp.make_robot("ur5")
ROBOTS = pytest.mark.parametrize("robot", [IRAMIS, UR5], ids=["iramis", "ur5"])
# Exports that are not called with values: a Protocol (isinstance checks), the error classes,
# the version string.
NOT_CALLED = {"RobotModel", "RcmplanError", "InvalidInputError", "__version__"}

lams = number(-0.5, 1.5)


def joint_arg(robot: Any) -> Arg:
    """Joint vectors: near home (within an eighth of each travel), anywhere finite, wrong."""
    n = len(robot.home)
    span = (robot.upper - robot.lower) / 8
    near = st.lists(st.floats(-1.0, 1.0), min_size=n, max_size=n).map(
        lambda d: robot.home + np.asarray(d) * span
    )
    good = st.one_of(near, near.map(list), vector(n, -1e3, 1e3).good)
    return Arg(good, vector(n, -1.2, 1.2).bad)


def joints(robot: Any) -> st.SearchStrategy[Any]:
    return joint_arg(robot).any()


def label(robot: Any, method: str) -> str:
    return f"{type(robot).__name__}.{method}"


def unit(x: Any) -> bool:
    return shaped((3,))(x) and abs(float(np.linalg.norm(x)) - 1.0) < 1e-9


def rigid(T: Any) -> bool:
    return shaped((4, 4))(T) and np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-9)


@ROBOTS
@examples(220)
@given(data=st.data())
def test_joint_queries_are_finite_or_refused(robot: Any, data: st.DataObject) -> None:
    q = data.draw(joints(robot))
    n, m = len(robot.home), len(robot.active)
    checks = {
        "tip": shaped((3,)), "needle_base": shaped((3,)), "needle_axis": unit,
        "tip_jacobian": shaped((3, m + 1)), "needle_angular_jacobian": shaped((3, m + 1)),
        "needle_angles_jacobian": shaped((2, m + 1)), "tool_pose": rigid,
        "tool_jacobian": shaped((6, n)), "joint_rates": shaped((n, n)),
        "singularity_measure": lambda v: 0.0 <= v <= 1.0,
        "singular_terms": lambda v: len(v) == 2 and finite(v[0]) and finite(v[1]),
        "actuators_from_joints": shaped((n,)),
    }  # fmt: skip
    if robot is IRAMIS:
        checks |= {"forward_kinematics": rigid, "jacobian": shaped((6, 6)),
                   "jacobian_05": shaped((6, 5)), "actuators_from_joints_jacobian": shaped((6, 6))}  # fmt: skip
    for method, ok in checks.items():
        probe(label(robot, method), getattr(robot, method), q, ok=ok, names=("q",))


@ROBOTS
@examples(200)
@given(data=st.data())
def test_needle_points_lie_on_the_needle_line_or_are_refused(
    robot: Any, data: st.DataObject
) -> None:
    q, lam = data.draw(one_bad(joint_arg(robot), lams))
    m = len(robot.active)

    def on_line(p: Any) -> bool:  # any finite lambda: the point on the needle's line
        base, tip = robot.needle_base(q), robot.tip(q)
        expected = base + float(lam) * (tip - base)
        return shaped((3,))(p) and np.allclose(
            p, expected, rtol=1e-9, atol=1e-12 * (1 + abs(float(lam)))
        )

    probe(label(robot, "needle_point"), robot.needle_point, q, lam, ok=on_line, names=("q", "lam"))
    probe(label(robot, "needle_point_jacobian"), robot.needle_point_jacobian, q, lam,
          ok=shaped((3, m + 1)), names=("q", "lam"))  # fmt: skip


@ROBOTS
@examples(200)
@given(data=st.data())
def test_actuator_maps_and_limits_are_finite_or_refused(robot: Any, data: st.DataObject) -> None:
    n = len(robot.home)
    s = data.draw(st.one_of(vectors(n, -0.05, 0.05), vectors(n, -7.0, 7.0)))
    probe(label(robot, "joints_from_actuators"), robot.joints_from_actuators, s,
          ok=shaped((n,)), names=("s",))  # fmt: skip
    probe(label(robot, "check_actuators"), robot.check_actuators, s, names=("s",),
          ok=lambda v: shaped((n,))(v) and np.all((robot.lower <= v) & (v <= robot.upper)))  # fmt: skip
    probe(label(robot, "actuator_margin"), robot.actuator_margin, s, ok=shaped((n,)),
          names=("s",))  # fmt: skip
    if robot is IRAMIS:
        probe("Iramis.slider_jacobian", robot.slider_jacobian, s, ok=shaped((6, 6)), names=("s",))
        probe("Iramis.joints_from_actuators_jacobian", robot.joints_from_actuators_jacobian, s,
              ok=shaped((6, 6)), names=("s",))  # fmt: skip


@ROBOTS
@examples(200)
@given(data=st.data())
def test_singularity_checks_are_refused_or_pass(robot: Any, data: st.DataObject) -> None:
    q, threshold = data.draw(one_bad(joint_arg(robot), optional(number(0.0, 0.5))))
    probe(label(robot, "check_singularity"), robot.check_singularity, q, threshold,
          ok=lambda v: v is None, names=("q", "threshold"))  # fmt: skip


@ROBOTS
@examples(60)
@given(data=st.data())
def test_needle_poses_put_the_tip_at_the_point_or_are_refused(
    robot: Any, data: st.DataObject
) -> None:
    tip0 = robot.tip(robot.home)
    near = st.lists(st.floats(-0.01, 0.01), min_size=3, max_size=3).map(
        lambda d: tip0 + np.array(d)
    )
    tips = Arg(near, st.one_of(vector(3, -20.0, 20.0).any(), near.map(lambda t: t + 1.0)))
    seeds = optional(joint_arg(robot))
    tip, phi, psi, seed = data.draw(one_bad(tips, number(-0.3, 0.3), number(-0.3, 0.3), seeds))
    n = len(robot.home)

    def there(q: Any) -> bool:
        return shaped((n,))(q) and np.allclose(robot.tip(q), np.asarray(tip, float), atol=1e-9)

    probe(label(robot, "needle_pose"), robot.needle_pose, tip, phi, psi, seed, ok=there,
          names=("tip", "phi", "psi", "seed"))  # fmt: skip


@examples(150)
@given(l6=optional(number(0.01, 0.2)).any())
def test_iramis_dh_tables_are_finite_or_refused(l6: Any) -> None:
    links = probe("Iramis.dh_links", IRAMIS.dh_links, l6, names=("l6",),
                  ok=lambda v: len(v) == 6 and all(finite(lk[1:]) for lk in v))  # fmt: skip
    if links is not None:
        probe("DHChain", rp.DHChain, links, ok=lambda c: c.n == 6)


def test_every_export_is_probed() -> None:
    """Each name of `rcmplan.__all__` (but NOT_CALLED) is called by a probe in these files: a
    probe labelled with the name, or one of the names the control tests probe in a loop."""
    from test_api_properties_control import LIMITS, TASKS

    text = "".join(p.read_text() for p in Path(__file__).parent.glob("test_api_properties*.py"))
    probed = set(re.findall(r'probe\(\s*"([A-Za-z_]+)', text)) | set(LIMITS) | set(TASKS)
    assert set(rp.__all__) - NOT_CALLED - probed == set()
