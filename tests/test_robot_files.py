"""Chains loaded from URDF and MJCF files equal Pinocchio's and MuJoCo's own kinematics."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from rcmplan import Iramis
from rcmplan.exceptions import (
    InvalidInputError,
    ModelFileError,
    UnknownFrameError,
    UnsupportedJointError,
)
from rcmplan.robot.chain import JointChain
from rcmplan.robot.library import ROBOT_FILES
from rcmplan.robot.mjcf import load_mjcf
from rcmplan.robot.shipped import panda_chain, robot_file, ur5_chain
from rcmplan.robot.urdf import load_urdf

from fd import fd_jacobian

TIPS = {"ur5": "tool0", "panda": "panda_link8"}
CHAINS = {"ur5": ur5_chain, "panda": panda_chain}

ARM_MJCF = """<mujoco model="arm4">
  <compiler angle="radian"/>
  <worldbody>
    <body name="mount" pos="0.1 -0.2 0.3" quat="0.9 0.1 0.3 -0.2">
      <body name="link1" pos="0 0 0.1" euler="0.2 0.1 0.4">
        <joint name="j1" type="hinge" axis="0 0 1" range="-2 2" ref="0.3" pos="0.01 0 0"/>
        <geom type="capsule" size="0.02" fromto="0 0 0 0 0 0.2"/>
        <body name="link2" pos="0 0.05 0.2" quat="0.7 0.7 0.1 0">
          <joint name="j2" type="hinge" axis="0 1 0.2" range="-1.5 1.5" pos="0 0 0.02"/>
          <geom type="capsule" size="0.02" fromto="0 0 0 0.25 0 0"/>
          <body name="link3" pos="0.25 0 0">
            <joint name="j3" type="slide" axis="1 0 0" range="-0.05 0.1" ref="0.02"/>
            <joint name="j4" type="hinge" axis="1 0.3 0" pos="0.03 0.01 0"/>
            <geom type="box" size="0.02 0.02 0.02"/>
            <site name="needle" pos="0.1 0.02 -0.01" euler="0.3 -0.5 1"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

INERTIAL = '<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'
ARM_URDF = """<robot name="arm3">
  <mujoco><compiler fusestatic="false" discardvisual="false"/></mujoco>
  <link name="base"/>
  {links}
  <joint name="a" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.2" rpy="0.1 0.2 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" velocity="1.5" effort="10"/></joint>
  <joint name="b" type="continuous"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.1 0 0.3" rpy="1.5707963267948966 0 0"/><axis xyz="0 0.6 0.8"/></joint>
  <joint name="bend" type="fixed"><parent link="l2"/><child link="l2b"/>
    <origin xyz="0 0.2 0" rpy="0 0.4 0"/></joint>
  <joint name="c" type="prismatic"><parent link="l2b"/><child link="l3"/>
    <origin xyz="0.05 0 0" rpy="0 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-0.1" upper="0.2" velocity="0.3" effort="10"/></joint>
  <joint name="tool" type="fixed"><parent link="l3"/><child link="flange"/>
    <origin xyz="0 0 0.08" rpy="-1.5707963267948966 0 0.5"/></joint>
</robot>
""".format(
    links="".join(
        f'<link name="{n}">{INERTIAL}</link>' for n in ("l1", "l2", "l2b", "l3", "flange")
    )
)


@pytest.fixture
def arm_xml(tmp_path: Path) -> Path:
    """The 4-joint MJCF arm (hinge with ref, slide, two joints in a body, site tip) on disk."""
    return written(tmp_path / "arm.xml", ARM_MJCF)


@pytest.fixture
def arm_urdf(tmp_path: Path) -> Path:
    """The URDF arm (revolute, continuous, fixed, prismatic, fixed tip) on disk."""
    return written(tmp_path / "arm.urdf", ARM_URDF)


def written(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def in_limits(rng: np.random.Generator, chain: JointChain, n: int) -> np.ndarray:
    """n random configurations inside the chain's limits."""
    return rng.uniform(chain.lower, chain.upper, size=(n, chain.n))


def pin_kinematics(name: str, chain: JointChain, qs: np.ndarray) -> list[tuple[np.ndarray, ...]]:
    """Pinocchio's flange pose and LOCAL_WORLD_ALIGNED Jacobian (chain joints' columns) per q."""
    model = pin.buildModelFromUrdf(str(robot_file(name)))
    data, frame = model.createData(), model.getFrameId(TIPS[name])
    joints = [model.joints[model.getJointId(j.name)] for j in chain.joints]
    out = []
    for q in qs:
        q_pin = pin.neutral(model)
        q_pin[[j.idx_q for j in joints]] = q
        pin.framesForwardKinematics(model, data, q_pin)
        J = pin.computeFrameJacobian(model, data, q_pin, frame, pin.LOCAL_WORLD_ALIGNED)
        out.append((data.oMf[frame].homogeneous, J[:, [j.idx_v for j in joints]]))
    return out


def mujoco_site(model: mujoco.MjModel, q: np.ndarray, site: str) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo's own world pose and (6, nv) Jacobian of a site at qpos = q."""
    data = mujoco.MjData(model)
    data.qpos[:] = q
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)  # cdof, which mj_jacSite reads
    s = model.site(site).id
    jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    mujoco.mj_jacSite(model, data, jacp, jacr, s)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = data.site_xmat[s].reshape(3, 3), data.site_xpos[s]
    return T, np.vstack([jacp, jacr])


def assert_same_kinematics(
    chain: JointChain, q: np.ndarray, T: np.ndarray, J: np.ndarray, atol: float = 1e-12
) -> None:
    np.testing.assert_allclose(chain.forward_kinematics(q), T, rtol=0, atol=atol)
    np.testing.assert_allclose(chain.jacobian(q), J, rtol=0, atol=atol)


@pytest.mark.parametrize("name", ROBOT_FILES)
def test_shipped_chain_pose_and_jacobian_equal_pinocchio(name: str) -> None:
    chain = CHAINS[name]()
    qs = in_limits(np.random.default_rng(7), chain, 50)
    for q, (T, J) in zip(qs, pin_kinematics(name, chain, qs), strict=True):
        assert_same_kinematics(chain, q, T, J)


@pytest.mark.parametrize("name", ROBOT_FILES)
def test_an_arm_s_tool_pose_is_its_chain_s_end_frame_times_the_needle_mount(name: str) -> None:
    from rcmplan.robot.registry import make_robot

    # The chain's pose is pinocchio's (above); the tool pose comes from the compiled kernels.
    arm = make_robot(name)
    for q in in_limits(np.random.default_rng(8), arm.chain, 20):
        expected = arm.chain.forward_kinematics(q) @ arm.needle.mount
        np.testing.assert_allclose(arm.tool_pose(q), expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", ROBOT_FILES)
def test_shipped_chain_ends_in_a_frame_whose_z_is_the_last_joint_axis(name: str) -> None:
    chain = CHAINS[name]()
    frames = chain.frames(in_limits(np.random.default_rng(8), chain, 1)[0])
    np.testing.assert_allclose(frames[-1, :3, 2], frames[-2, :3, :3] @ chain.axes[-1], atol=1e-15)


def test_shipped_chains_carry_the_urdf_limits_and_speeds() -> None:
    ur5, panda = ur5_chain(), panda_chain()
    assert ur5.joint_names[0] == "shoulder_pan_joint" and ur5.velocity[0] == 3.15
    assert panda.n == 7 and (panda.lower[3], panda.upper[3]) == (-3.0718, -0.0698)


def test_mjcf_chain_with_a_site_tip_equals_mujoco_kinematics(arm_xml: Path) -> None:
    chain, model = load_mjcf(arm_xml, "needle"), mujoco.MjModel.from_xml_path(str(arm_xml))
    assert chain.joint_names == ("j1", "j2", "j3", "j4") and chain.name == "arm4"
    for q in in_limits(np.random.default_rng(9), chain, 50):
        assert_same_kinematics(chain, q, *mujoco_site(model, q, "needle"))


def test_mjcf_chain_from_an_inner_root_body_is_placed_where_that_body_is(arm_xml: Path) -> None:
    whole, inner = load_mjcf(arm_xml, "needle"), load_mjcf(arm_xml, "needle", root_body="mount")
    q = in_limits(np.random.default_rng(10), whole, 1)[0]
    np.testing.assert_allclose(inner.forward_kinematics(q), whole.forward_kinematics(q), atol=1e-14)
    assert not np.allclose(inner.base, np.eye(4))


def test_mjcf_limits_are_joint_ranges_and_unlimited_hinges_get_a_full_turn(arm_xml: Path) -> None:
    chain = load_mjcf(arm_xml, "link3")
    np.testing.assert_allclose(chain.lower, [-2, -1.5, -0.05, -math.pi])
    np.testing.assert_allclose(chain.upper, [2, 1.5, 0.1, math.pi])


def test_urdf_round_trips_through_mujoco_and_its_saved_mjcf(arm_urdf: Path) -> None:
    chain = load_urdf(arm_urdf, "flange")
    saved = arm_urdf.with_name("arm_saved.xml")
    mujoco.mj_saveLastXML(str(saved), mujoco.MjModel.from_xml_path(str(arm_urdf)))
    # MuJoCo saves 6 significant digits, so its saved MJCF agrees to about 1e-6 only
    for other, atol in ((load_mjcf(arm_urdf, "flange"), 1e-12), (load_mjcf(saved, "flange"), 1e-5)):
        assert other.joint_names == chain.joint_names == ("a", "b", "c")
        for q in in_limits(np.random.default_rng(11), chain, 20):
            assert_same_kinematics(other, q, chain.forward_kinematics(q), chain.jacobian(q), atol)


def test_urdf_continuous_joint_gets_a_full_turn_and_fixed_joints_fold_away(arm_urdf: Path) -> None:
    chain = load_urdf(arm_urdf, "flange")
    assert chain.name == "arm3" and chain.prismatic.tolist() == [False, False, True]
    assert (chain.lower[1], chain.upper[1], chain.velocity[1]) == (-math.pi, math.pi, 1.0)
    assert chain.velocity[2] == 0.3
    np.testing.assert_allclose(chain.tip[:3, 3], [0.0, 0.0, 0.08])


def test_urdf_chain_from_an_inner_root_frame_matches_the_whole_chain(arm_urdf: Path) -> None:
    whole, inner = load_urdf(arm_urdf, "flange"), load_urdf(arm_urdf, "flange", root_frame="l1")
    q = np.array([0.0, 0.4, 0.1])
    assert inner.joint_names == ("b", "c")
    np.testing.assert_allclose(inner.forward_kinematics(q[1:]), whole.forward_kinematics(q))


def assert_same_chain(a: JointChain, b: JointChain) -> None:
    """Every array of the two chains equal to the bit, and the same names."""
    assert (a.name, a.joint_names) == (b.name, b.joint_names)
    for field in ("origins", "axes", "prismatic", "lower", "upper", "velocity", "tip", "base"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)


def test_a_urdf_read_again_comes_from_the_cache_equal_to_the_bit(
    arm_urdf: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from rcmplan.robot import urdf

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    parsed = load_urdf(arm_urdf, "flange", root_frame="l1", name="inner")
    assert len(list((tmp_path / "cache" / "rcmplan" / "urdf").glob("*.json"))) == 1

    def no_parser(path: object) -> None:
        raise AssertionError(f"parsed {path} again")

    monkeypatch.setattr(urdf, "_read", no_parser)
    assert_same_chain(load_urdf(arm_urdf, "flange", root_frame="l1", name="inner"), parsed)
    with pytest.raises(AssertionError, match="parsed"):  # another request: the parser again
        load_urdf(arm_urdf, "flange")
    arm_urdf.write_text(ARM_URDF.replace('velocity="0.3"', 'velocity="0.4"'))
    with pytest.raises(AssertionError, match="parsed"):  # another file: the parser again
        load_urdf(arm_urdf, "flange", root_frame="l1", name="inner")


def test_a_broken_or_unwritable_urdf_cache_is_passed_over(
    arm_urdf: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    parsed = load_urdf(arm_urdf, "flange")
    (kept,) = (tmp_path / "cache" / "rcmplan" / "urdf").glob("*.json")
    for broken in ("{", '{"name": "arm3"}', kept.read_text().replace("0.3", '"fast"')):
        kept.write_text(broken)
        assert_same_chain(load_urdf(arm_urdf, "flange"), parsed)  # parsed, and kept again
        assert kept.read_text() != broken
    (tmp_path / "file").write_text("not a folder")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "file"))
    assert_same_chain(load_urdf(arm_urdf, "flange"), parsed)


def test_dh_chain_of_iramis_equals_its_closed_forms() -> None:
    robot = Iramis()
    chain = JointChain.from_dh(robot.chain)
    rng = np.random.default_rng(12)
    for q in rng.uniform(-1.0, 1.0, size=(50, 6)) * [0.03, 1.2, 0.03, 1.2, 0.03, 1.2]:
        assert_same_kinematics(chain, q, robot.forward_kinematics(q), robot.jacobian(q))


@pytest.mark.parametrize("make", [ur5_chain, panda_chain, "mjcf"])
def test_chain_jacobian_equals_finite_differences_of_its_pose(make, arm_xml: Path) -> None:
    chain = load_mjcf(arm_xml, "needle") if make == "mjcf" else make()
    point = np.array([0.01, -0.02, 0.1])
    offset = np.eye(4)
    offset[:3, 3] = point
    for q in in_limits(np.random.default_rng(13), chain, 10):
        J_fd = fd_jacobian(chain.forward_kinematics, q)
        np.testing.assert_allclose(chain.jacobian(q), J_fd, rtol=0, atol=1e-8)
        J_fd = fd_jacobian(lambda x: chain.forward_kinematics(x) @ offset, q)
        np.testing.assert_allclose(chain.jacobian(q, point), J_fd, rtol=0, atol=1e-8)


def test_missing_urdf_frame_raises_naming_it_and_the_links_that_exist() -> None:
    with pytest.raises(UnknownFrameError, match="tool9") as info:
        load_urdf(robot_file("ur5"), "tool9")
    assert info.value.frame == "tool9" and "tool0" in info.value.frames
    assert "ee_link" in str(info.value)


def test_missing_mjcf_frame_raises_naming_it_and_the_bodies_and_sites(arm_xml: Path) -> None:
    with pytest.raises(UnknownFrameError, match="nedle") as info:
        load_mjcf(arm_xml, "nedle")
    assert {"needle", "link3", "mount"} <= set(info.value.frames)
    with pytest.raises(UnknownFrameError, match="root_body"):
        load_mjcf(arm_xml, "needle", root_body="link9")


def test_root_that_is_not_above_the_tip_raises_naming_the_ancestors(arm_urdf: Path) -> None:
    with pytest.raises(UnknownFrameError, match="'l3'") as info:
        load_urdf(arm_urdf, "l2", root_frame="l3")
    assert info.value.frames == ("l1", "base")


@pytest.mark.parametrize("loader", [load_urdf, load_mjcf])
def test_bad_model_file_raises_naming_the_file_and_the_reason(tmp_path: Path, loader) -> None:
    bad = written(tmp_path / "broken.xml", "<robot name='x'><link name='a'><joint")
    with pytest.raises(ModelFileError, match=r"broken\.xml") as info:
        loader(bad, "a")
    assert info.value.path == bad and "line" in info.value.reason.lower()  # the parser's reason
    with pytest.raises(ModelFileError, match="no such file"):
        loader(tmp_path / "absent.urdf", "a")


def test_mimic_joint_on_the_path_raises_naming_the_joint() -> None:
    with pytest.raises(UnsupportedJointError, match="panda_finger_joint2") as info:
        load_urdf(robot_file("panda"), "panda_rightfinger")
    assert info.value.kind == "mimic"


def test_floating_urdf_joint_raises_naming_the_joint(tmp_path: Path) -> None:
    text = ARM_URDF.replace('name="a" type="revolute"', 'name="a" type="floating"')
    with pytest.raises(UnsupportedJointError, match=r"'a'.*floating"):
        load_urdf(written(tmp_path / "float.urdf", text), "flange")


def test_ball_and_coupled_mjcf_joints_raise_naming_the_joint(tmp_path: Path) -> None:
    ball = ARM_MJCF.replace('type="hinge" axis="0 1 0.2" range="-1.5 1.5"', 'type="ball"')
    with pytest.raises(UnsupportedJointError, match=r"'j2'.*ball"):
        load_mjcf(written(tmp_path / "ball.xml", ball), "needle")
    tie = '<equality><joint joint1="j4" joint2="j1"/></equality></mujoco>'
    coupled = written(tmp_path / "coupled.xml", ARM_MJCF.replace("</mujoco>", tie))
    with pytest.raises(UnsupportedJointError, match="'j1'"):
        load_mjcf(coupled, "needle")


def test_unknown_robot_name_raises_listing_the_shipped_robots() -> None:
    with pytest.raises(InvalidInputError, match="panda, ur5"):
        robot_file("kuka")
