"""Offscreen rendering: images are not blank, the needle tip is drawn where FK projects it."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import imageio.v2 as iio
import numpy as np
import pytest

from rcmplan.cli import render as render_cli
from rcmplan.control.log import RunLog
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.registry import make_robot
from rcmplan.sim.mujoco.arm_plant import ArmPlant
from rcmplan.sim.mujoco.plant import MujocoPlant
from rcmplan.sim.mujoco.render import SceneRenderer, animate, save_animation, save_png

W, H = 320, 240


@pytest.fixture(scope="module")
def plant() -> MujocoPlant:
    return MujocoPlant(mode="kinematic")


@pytest.fixture(scope="module")
def renderer(plant: MujocoPlant) -> SceneRenderer:
    return SceneRenderer(plant.scene()[0], W, H)


def needle_end_pixel(
    renderer: SceneRenderer, plant: MujocoPlant | ArmPlant
) -> tuple[np.ndarray, np.ndarray]:
    """(projected FK tip, needle pixel farthest along the projected needle direction)."""
    robot = plant.robot
    q = robot.joints_from_actuators(plant.read_actuators())
    tip = renderer.project(plant.scene()[1], robot.tip(q))
    base = renderer.project(plant.scene()[1], robot.needle_point(q, 0.0))
    seg = renderer.segment(plant.scene()[1])
    v, u = np.nonzero(seg == plant.scene()[0].geom("needle").id)
    pixels = np.column_stack([u + 0.5, v + 0.5])  # pixel centres
    along = (pixels - base) @ (tip - base) / np.linalg.norm(tip - base)
    return tip, pixels[int(np.argmax(along))]


def test_snapshot_is_not_blank(plant: MujocoPlant, renderer: SceneRenderer) -> None:
    plant.reset(plant.robot.home_actuators)
    for camera in ("overview", "closeup"):
        img = renderer.render(plant.scene()[1], camera)
        assert img.shape == (H, W, 3) and img.dtype == np.uint8
        assert img.std() > 10.0
        assert len(np.unique(img.reshape(-1, 3), axis=0)) > 100


@pytest.mark.parametrize("s_mm", [(0, 0, 0, 0, 0, 0), (2, -1, 1, 2, 6, 0.3), (-3, 1, 0, -2, 4, 0)])
def test_needle_tip_is_drawn_where_forward_kinematics_projects_it(
    plant: MujocoPlant, renderer: SceneRenderer, s_mm: tuple[float, ...]
) -> None:
    s = np.array(s_mm, dtype=float)
    s[:5] *= 1e-3
    plant.reset(s)
    tip, end = needle_end_pixel(renderer, plant)
    assert 0 < tip[0] < W and 0 < tip[1] < H
    assert np.linalg.norm(end - tip) < 1.5  # pixels


def test_projection_rejects_points_behind_the_camera(
    plant: MujocoPlant, renderer: SceneRenderer
) -> None:
    cam = plant.scene()[1].cam("closeup")
    behind = cam.xpos + cam.xmat.reshape(3, 3)[:, 2] * 0.1  # cameras look along -z
    with pytest.raises(InvalidInputError, match="in front of the camera"):
        renderer.project(plant.scene()[1], behind)


def test_unknown_camera_lists_the_cameras(plant: MujocoPlant, renderer: SceneRenderer) -> None:
    with pytest.raises(InvalidInputError, match="closeup"):
        renderer.render(plant.scene()[1], "top")


def test_animation_with_tip_trace_is_written_as_gif(
    plant: MujocoPlant, renderer: SceneRenderer, tmp_path: Path
) -> None:
    t = np.linspace(0.0, 1.0, 40)[:, None]
    sliders = t * np.array([0.0, 0.0, 0.0, 0.0, 8e-3, 0.0])
    frames = animate(plant, sliders, renderer, frames=5)
    path = save_animation(tmp_path / "move.gif", frames, fps=10)
    read = iio.mimread(path)
    assert len(read) == 5
    assert not np.array_equal(read[0], read[-1])  # the needle moved and left a trace
    png = save_png(tmp_path / "last.png", frames[-1])
    assert iio.imread(png).shape == (H, W, 3)


def test_animation_is_written_as_mp4(
    plant: MujocoPlant, renderer: SceneRenderer, tmp_path: Path
) -> None:
    t = np.linspace(0.0, 1.0, 20)[:, None]
    frames = animate(plant, t * np.array([0.0, 0.0, 0.0, 0.0, 8e-3, 0.0]), renderer, frames=4)
    path = save_animation(tmp_path / "move.mp4", frames, fps=10)
    read = iio.mimread(path, format="FFMPEG")
    assert len(read) == 4 and read[0].shape[:2] == (H, W)
    assert np.abs(read[-1].astype(float) - frames[-1]).mean() < 10  # lossy, but the same image


def test_mp4_without_imageio_ffmpeg_names_the_video_extra(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    import sys

    from rcmplan.exceptions import MissingExtraError

    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)
    with pytest.raises(MissingExtraError, match=r"rcmplan\[video\]"):
        save_animation(tmp_path / "a.mp4", [np.zeros((16, 16, 3), dtype=np.uint8)])


def test_unknown_animation_format_is_rejected(tmp_path: Path) -> None:
    frame = np.zeros((4, 4, 3), dtype=np.uint8)
    with pytest.raises(InvalidInputError, match=r"\.gif or \.mp4"):
        save_animation(tmp_path / "a.avi", [frame])


def test_render_command_writes_snapshots_and_an_animation(tmp_path: Path) -> None:
    parser = argparse.ArgumentParser()
    render_cli.register(parser.add_subparsers(dest="command"))  # as main's parser
    args = parser.parse_args(
        ["render", "--out", str(tmp_path), "--width", "160", "--height", "120", "--frames", "4"]
    )
    assert args.run(args) == 0
    names = sorted(p.name for p in (tmp_path / "figures").iterdir())
    assert names == ["default.gif", "default_end_closeup.png", "home_closeup.png",
                     "home_overview.png"]  # fmt: skip
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["status"] == "ok" and summary["scenario"] == "default"
    assert summary["command"] == "render"
    assert sorted(Path(p).name for p in summary["figures"].values()) == names
    assert len(RunLog.load_npz(tmp_path / "log.npz")) == summary["iterations"]


# An arm's scene: the physics model with what a camera needs (`arm_model`'s scenery).


@pytest.fixture(scope="module")
def arm_plant() -> ArmPlant:
    return ArmPlant(make_robot("ur5"), mode="kinematic")


def test_an_arms_scene_adds_only_what_a_camera_sees_to_its_physics(arm_plant: ArmPlant) -> None:
    """The scene's links, floor, light and cameras carry no mass and make no contact: the
    bodies, joints, actuators and inertias are the physics model's (which has no camera)."""
    physics, (scene, _) = arm_plant.model, arm_plant.scene()
    assert physics.ncam == 0 and scene.ncam == 2
    assert (scene.nbody, scene.nq, scene.nu) == (physics.nbody, physics.nq, physics.nu)
    assert np.array_equal(scene.body_mass, physics.body_mass)
    assert np.array_equal(scene.body_inertia, physics.body_inertia)
    drawn = scene.ngeom - physics.ngeom
    assert drawn > arm_plant.robot.chain.n  # a capsule or a sphere per link, and the floor
    assert scene.geom_contype.sum() == physics.geom_contype.sum()  # none of them collides
    assert scene.geom_conaffinity.sum() == physics.geom_conaffinity.sum()


@pytest.mark.parametrize("turn", [0.0, 0.004, -0.006])  # [rad]: the tip within the closeup
def test_an_arms_needle_tip_is_drawn_where_forward_kinematics_projects_it(
    arm_plant: ArmPlant, turn: float
) -> None:
    """Both cameras see the arm; the closeup draws the needle's end at the projected tip."""
    arm = arm_plant.robot
    q = arm.home.copy()
    q[list(arm.active)] += turn * np.array([1.0, -1.0, 1.0, -1.0, 1.0])
    arm_plant.reset(q)
    model, data = arm_plant.scene()
    renderer = SceneRenderer(model, W, H)
    try:
        for camera in ("overview", "closeup"):
            img = renderer.render(data, camera)
            assert img.std() > 10.0 and len(np.unique(img.reshape(-1, 3), axis=0)) > 100
        tip, end = needle_end_pixel(renderer, arm_plant)
        assert 0 < tip[0] < W and 0 < tip[1] < H
        assert np.linalg.norm(end - tip) < 1.5  # pixels
    finally:
        renderer.close()
        arm_plant.reset(arm.home)


def test_render_command_draws_an_arms_run(tmp_path: Path) -> None:
    parser = argparse.ArgumentParser()
    render_cli.register(parser.add_subparsers(dest="command"))  # as main's parser
    args = parser.parse_args(["render", "--robot", "ur5", "--out", str(tmp_path), "--width",
                              "160", "--height", "120", "--frames", "4"])  # fmt: skip
    assert args.run(args) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["status"] == "ok" and summary["robot"] == "ur5"
    gif = iio.mimread(tmp_path / "figures" / "default.gif")
    assert len(gif) == 4 and not np.array_equal(gif[0], gif[-1])  # the needle moved
    log = RunLog.load_npz(tmp_path / "log.npz")
    assert log.sliders.shape[1] == 6 and len(log) == summary["iterations"]


def test_an_arms_scene_draws_a_curved_needles_arc_ending_at_the_models_tip() -> None:
    """The curved scenario's needle on the UR5: the arc's tip site in the scene a camera sees
    is the curved model's tip (`CurvedTipRobot.tip`), at home and at a moved pose; the physics
    model has no arc."""
    from rcmplan.scene.scenario import load_scenario

    needle = load_scenario("curved").needle
    robot = needle.fit(make_robot("ur5"))
    plant = ArmPlant(robot.base, mode="kinematic", needle_arc=needle.arc())
    for q in (robot.home, robot.home + np.array([0.02, -0.03, 0.04, 0.0, -0.02, 0.7])):
        plant.reset(q)
        model, data = plant.scene()
        site = model.site("needle_arc_tip").id
        assert data.site_xpos[site] == pytest.approx(robot.tip(q), abs=1e-9)
    assert "needle_arc_tip" not in [plant.model.site(i).name for i in range(plant.model.nsite)]


KINOVA_Z = """[robot]
name = "kinova-z"
urdf = "package://example-robot-data/kinova_description/robots/kinova.urdf"
flange = "j2s6s200_end_effector"
needle_axis = "+z"
home = [0.43072220572976727, 2.1257375254510467, 4.8215351907011925, 0.5411800607078334, 1.0471975511962002, 1.7967668521241829]
"""


@pytest.mark.parametrize("name", ["ur5", "panda", "kinova-z"])
def test_an_arms_cameras_see_the_eye_and_the_needle_past_its_links(tmp_path, name) -> None:  # type: ignore[no-untyped-def]
    """At home, the overview shows the eye and the closeup the eye and the needle, wherever the
    links stand: on the Kinova with its needle across the flange the overview from iRAM!S's
    side is hidden by the arm, and the scene turns the camera about the vertical instead."""
    from rcmplan.robot.robot_file import load_robot_file

    if name == "kinova-z":
        (tmp_path / "k.toml").write_text(KINOVA_Z)
        arm = load_robot_file(tmp_path / "k.toml").arm
    else:
        arm = make_robot(name)
    plant = ArmPlant(arm, mode="kinematic")
    model, data = plant.scene()
    renderer = SceneRenderer(model, W, H)
    try:
        for camera, geoms in (("overview", ("eyeball",)), ("closeup", ("eyeball", "needle"))):
            seen = renderer.segment(data, camera)
            for geom in geoms:
                assert np.count_nonzero(seen == model.geom(geom).id) > 0, (camera, geom)
    finally:
        renderer.close()
