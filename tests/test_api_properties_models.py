"""Generated inputs to the robot, needle and chain constructors and the robot loaders (the rule:
tests/api_inputs.py): a typed error naming the argument, or a finite object within bounds."""

from __future__ import annotations

import hashlib
import tomllib
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

import rcmplan as rp
from rcmplan.robot.library import shipped_robot_file
from rcmplan.robot.robot_file import model_path, read_robot_file

from api_inputs import (
    FOLDER,
    JUNK,
    Arg,
    choice,
    examples,
    fields_finite,
    finite,
    matrix,
    number,
    one_bad,
    optional,
    probe,
    shaped,
    vector,
)

UR5 = rp.make_robot("ur5")
UR5_FILE = tomllib.loads(shipped_robot_file("ur5").read_text())["robot"]
UR5_URDF = model_path(read_robot_file(shipped_robot_file("ur5")))
MJCF = Path(rp.__file__).parent / "sim" / "mujoco" / "assets" / "robot.xml"
PARAMETERS = [f.name for f in fields(rp.IramisParameters) if f.name != "sources"]


def written(content: str | bytes, suffix: str) -> Path:
    """A file in FOLDER holding `content` (named by its hash)."""
    data = content.encode("utf-8", "surrogatepass") if isinstance(content, str) else content
    path = FOLDER / (hashlib.sha1(data).hexdigest()[:16] + suffix)
    path.write_bytes(data)
    return path


@examples(300)
@given(name=st.sampled_from(PARAMETERS), data=st.data())
def test_iramis_parameters_are_finite_and_bounded_or_refused(
    name: str, data: st.DataObject
) -> None:
    tuple_field = name in ("slider_lower", "slider_upper", "slider_speed")
    value = data.draw((vector(6, 0.001, 0.04) if tuple_field else number(0.001, 0.1)).any())
    if name == "slider_lower" and isinstance(value, list) and len(value) == 6:
        value = [-v if isinstance(v, float) else v for v in value]
    params = probe("IramisParameters", lambda: rp.IramisParameters(**{name: value}),
                   ok=fields_finite, names=(name,))  # fmt: skip
    probe("Iramis", rp.Iramis, params if params is not None else value, names=("params",),
          ok=lambda r: finite(r.P) and np.all(r.lower < r.upper) and r.needle_length > 0)  # fmt: skip


def pair(v: Any) -> bool:
    return len(v) == 2 and finite(v)


@examples(250)
@given(args=one_bad(number(0.001, 0.1), number(-0.04, 0.04), number(-1.4, 1.4)))
def test_pcjm_maps_are_finite_or_refused(args: tuple[Any, ...]) -> None:
    spacing, a, b = args
    pcjm = probe("Pcjm", rp.Pcjm, spacing, ok=fields_finite, names=("spacing",)) or rp.Pcjm(0.03)
    probe("Pcjm.joints", pcjm.joints, a, b, ok=pair, names=("L1", "L2"))
    probe("Pcjm.sliders", pcjm.sliders, a, b, ok=pair, names=("q_lin", "q_rot"))
    probe("Pcjm.joints_jacobian", pcjm.joints_jacobian, a, b, ok=shaped((2, 2)), names=("L1", "L2"))
    probe("Pcjm.sliders_jacobian", pcjm.sliders_jacobian, b, ok=shaped((2, 2)), names=("q_rot",))


def unit_axis(needle: Any) -> bool:
    return fields_finite(needle) and abs(np.linalg.norm(needle.axis_local()) - 1) < 1e-9


@examples(300)
@given(args=one_bad(number(0.001, 0.2), matrix(np.eye(4)), number(0.0, 1.0), number(0.001, 0.05),
                    number(0.0, 1.5)))  # fmt: skip
def test_needles_are_finite_or_refused(args: tuple[Any, ...]) -> None:
    length, mount, lam, radius, arc = args
    straight = probe("StraightNeedle", rp.StraightNeedle, length, mount, ok=unit_axis,
                     names=("length", "mount"))  # fmt: skip
    if straight is not None:
        probe(
            "StraightNeedle.point_local", straight.point_local, lam, ok=shaped((3,)), names=("lam",)
        )
    curved = probe("CurvedNeedle", rp.CurvedNeedle, length, radius, arc, mount, ok=fields_finite,
                   names=("shaft_length", "radius", "arc_angle", "mount"))  # fmt: skip
    if curved is not None:
        probe("CurvedNeedle.arc_local", curved.arc_local, lam, ok=shaped((3,)), names=("t",))
        probe(
            "CurvedNeedle.tangent_local", curved.tangent_local, lam, ok=shaped((3,)), names=("t",)
        )
        probe("CurvedNeedle.chord_angle", curved.chord_angle, length, ok=finite, names=("depth",))


CHAIN_JOINT = ("name", "kind", "origin", "axis", "lower", "upper", "velocity")
CHAIN_JOINT_ARGS = (
    Arg(st.text(max_size=3), JUNK), choice(["revolute", "prismatic"], ["fixed", "Revolute"]),
    matrix(np.eye(4)), vector(3, -1.0, 1.0), number(-3.2, -0.1), number(0.1, 3.2), number(0.1, 10.0),
)  # fmt: skip
DH_LINK = ("joint", "theta", "d", "a", "alpha")
DH_LINK_ARGS = (
    choice(["revolute", "prismatic"], ["fixed", None]), number(-3.2, 3.2), number(-0.2, 0.2),
    number(-0.2, 0.2), number(-3.2, 3.2),
)  # fmt: skip


def mostly_good(args: tuple[Arg, ...]) -> st.SearchStrategy[tuple[Any, ...]]:
    """Arguments all good nine times in ten, else one_bad's."""
    good = st.tuples(*(a.good for a in args))
    return st.integers(0, 9).flatmap(lambda k: good if k else one_bad(*args))


@examples(300)
@given(joint_args=st.lists(mostly_good(CHAIN_JOINT_ARGS), min_size=1, max_size=4),
       args=one_bad(optional(matrix(np.eye(4))), optional(matrix(np.eye(4))),
                    Arg(st.text(max_size=4), JUNK)), data=st.data())  # fmt: skip
def test_joint_chains_are_finite_or_refused(joint_args: list[Any], args: tuple[Any, ...],
                                            data: st.DataObject) -> None:  # fmt: skip
    tip, base, name = args
    joints = [probe("ChainJoint", rp.ChainJoint, *a, ok=fields_finite, names=CHAIN_JOINT)
              for a in joint_args]  # fmt: skip
    chain = probe("JointChain", rp.JointChain, joints, tip, base, name, ok=lambda c: c.n >= 1,
                  names=("joints", "tip", "base", "name"))  # fmt: skip
    if chain is None:
        return
    n = chain.n
    q, point = data.draw(one_bad(vector(n, -1.0, 1.0), optional(vector(3, -0.1, 0.1))))
    probe("JointChain.frames", chain.frames, q, ok=shaped((n + 1, 4, 4)), names=("q",))
    probe("JointChain.forward_kinematics", chain.forward_kinematics, q, ok=shaped((4, 4)),
          names=("q",))  # fmt: skip
    probe("JointChain.jacobian", chain.jacobian, q, point, ok=shaped((6, n)), names=("q", "point"))
    probe("JointChain.placed", chain.placed, base, tip, ok=lambda c: c.n == n,
          names=("base", "tip"))  # fmt: skip


@examples(300)
@given(link_args=st.one_of(st.lists(mostly_good(DH_LINK_ARGS), min_size=1, max_size=4), JUNK),
       base=optional(matrix(np.eye(4))).any(), data=st.data())  # fmt: skip
def test_dh_chains_are_finite_or_refused(link_args: Any, base: Any, data: st.DataObject) -> None:
    links = link_args
    if isinstance(link_args, list) and all(isinstance(a, tuple) for a in link_args):
        links = [probe("DHLink", rp.DHLink, *a, ok=lambda lk: finite(lk[1:]), names=DH_LINK)
                 for a in link_args]  # fmt: skip
    chain = probe("DHChain", rp.DHChain, links, base, ok=lambda c: c.n >= 1 and finite(c.base),
                  names=("links", "base"))  # fmt: skip
    if chain is None:
        return
    n = chain.n
    links_at = Arg(st.one_of(st.none(), st.integers(0, n)), number(0, n).bad)
    q, link, point = data.draw(
        one_bad(vector(n, -1.0, 1.0), links_at, optional(vector(3, -0.1, 0.1)))
    )
    probe("DHChain.frames", chain.frames, q, ok=shaped((n + 1, 4, 4)), names=("q",))
    probe("DHChain.jacobian", chain.jacobian, q, link, point, ok=shaped((6, n)),
          names=("q", "link", "point"))  # fmt: skip


ARM = ("chain", "needle", "home", "name", "roll_joint", "singular_threshold", "resolution", "robot")


@examples(150)
@given(args=one_bad(
    choice([UR5.chain], [None, "ur5", rp.Iramis().chain]), choice([UR5.needle], [None, 0.06]),
    Arg(st.sampled_from([UR5.home, UR5.home.tolist()]), vector(6, -1.5, 1.5).any()),
    Arg(st.text(max_size=4), JUNK), choice([5, None], [-1, 6, 2, 5.0, True, "5"]),
    number(0.0, 0.5), number(1e-9, 1e-6),
))  # fmt: skip
def test_serial_arms_are_finite_or_refused(args: tuple[Any, ...]) -> None:
    chain, needle, home, name, roll, threshold, resolution = args
    probe("SerialArm", rp.SerialArm, chain, needle, home, name, roll, threshold, resolution,
          ok=lambda a: finite(a.home), names=ARM)  # fmt: skip
    probe("needle_arm", rp.needle_arm, chain, home, name, needle, threshold,
          ok=lambda a: finite(a.home), names=ARM)  # fmt: skip


toml_values = st.one_of(
    st.text(max_size=6),
    st.integers(-(2**63), 2**63 - 1),
    st.floats(allow_nan=True),
    st.booleans(),
    st.lists(st.floats(-7, 7), max_size=8),
    st.just({"a": 1}),
)


def toml_text(table: dict[str, Any]) -> str:
    def value(v: Any) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, float):
            return (
                "nan"
                if v != v
                else ("inf" if v == float("inf") else "-inf" if v == -float("inf") else repr(v))
            )
        if isinstance(v, str):
            return '"' + v.encode("unicode_escape").decode("ascii").replace('"', '\\"') + '"'
        if isinstance(v, list):
            return "[" + ", ".join(value(e) for e in v) + "]"
        if isinstance(v, dict):
            return "{" + ", ".join(f"{k} = {value(e)}" for k, e in v.items()) + "}"
        return str(v)

    return "[robot]\n" + "".join(f"{k} = {value(v)}\n" for k, v in table.items())


@st.composite
def robot_files(draw: st.DrawFn) -> Path:
    """The UR5's robot file with one key changed, removed or added, or a file that is no robot
    file (the model path made absolute so that the file may live anywhere)."""
    table = {**UR5_FILE, "urdf": str(UR5_URDF)}
    kind = draw(st.sampled_from(["same", "change", "remove", "add", "home", "raw"]))
    if kind == "raw":
        raw = draw(st.one_of(st.binary(max_size=40), st.text(max_size=40),
                             st.just("[robot]\nname = 1\n[other]\n"), st.just("x" * 70000)))  # fmt: skip
        return written(raw, draw(st.sampled_from([".toml", ".txt"])))
    key = draw(st.sampled_from([*table, "mjcf", "extra"]))
    if kind == "remove":
        table.pop(key, None)
    elif kind == "home":
        near = st.lists(st.floats(-0.1, 0.1), min_size=6, max_size=6).map(
            lambda d: (np.asarray(UR5_FILE["home"]) + d).tolist()
        )
        table["home"] = draw(st.one_of(near, st.lists(st.floats(-7, 7), min_size=5, max_size=7)))
    elif kind == "same":
        return written(toml_text(table), ".toml")
    else:
        table[key] = draw(toml_values if key not in ("urdf", "mjcf") else st.sampled_from(
            [str(UR5_URDF), "missing.urdf", "package://example-robot-data/none.urdf", str(MJCF),
             "package://other/x.urdf"]))  # fmt: skip
    return written(toml_text(table), ".toml")


@examples(120)
@given(path=st.one_of(robot_files(), JUNK, st.sampled_from(["ur5", "panda", "iramis", "none.toml",
                                                           str(FOLDER), "UR5"])))  # fmt: skip
def test_robot_files_load_or_are_refused(path: Any) -> None:
    arm = lambda r: finite(r.home) and r.check_actuators(r.home_actuators) is not None  # noqa: E731
    probe("make_robot", rp.make_robot, path, ok=arm, names=("robot", "name_or_path"))
    if isinstance(path, Path):
        probe("load_robot_file", rp.load_robot_file, path, ok=lambda r: arm(r.arm), names=("path",))


model_texts = st.one_of(
    st.text(max_size=30),
    st.just("<robot/>"),
    st.just("<robot name='x'><link name='a'/></robot>"),
    st.just("<mujoco/>"),
    st.just("<mujoco><worldbody><body name='b'/></worldbody></mujoco>"),
    st.just("<robot"),
)


def chain_ok(chain: Any) -> bool:
    return chain.n >= 1 and finite(chain.base) and finite(chain.tip)


model_files = st.one_of(model_texts.map(lambda t: written(t, ".xml")),
                        st.just(FOLDER / "none.urdf"), st.just(FOLDER), JUNK)  # fmt: skip


@examples(120)
@given(args=one_bad(
    Arg(st.sampled_from([UR5_URDF, str(UR5_URDF)]), model_files),
    choice(["tool0", "wrist_3_link", "forearm_link"], ["needle", "", "base_link", "world"]),
    choice([None, "base_link"], ["tool0", "nowhere"]), choice([None, "ur5"], [3]),
))  # fmt: skip
def test_urdf_files_load_or_are_refused(args: tuple[Any, ...]) -> None:
    probe("load_urdf", rp.load_urdf, *args, ok=chain_ok,
          names=("path", "tip_frame", "root_frame", "name"))  # fmt: skip


@examples(120)
@given(args=one_bad(
    Arg(st.sampled_from([MJCF, str(MJCF)]), st.one_of(model_files, st.just(UR5_URDF))),
    choice(["needle_tip", "frame5", "slider_L3"], ["base", "", "needle"]),
    choice([None, "base"], ["needle_tip", "nowhere"]),
))  # fmt: skip
def test_mjcf_files_load_or_are_refused(args: tuple[Any, ...]) -> None:
    probe("load_mjcf", rp.load_mjcf, *args, ok=chain_ok, names=("path", "tip_frame", "root_body"))
