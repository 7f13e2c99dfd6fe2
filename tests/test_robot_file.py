"""Robots from one TOML file (rcmplan.robot.robot_file): shipped and user arms, the home search,
and the typed errors of bad files, from the API and from the command line."""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from heavy import heavy
from rcmplan.cli import main
from rcmplan.exceptions import InvalidInputError, NoHomeFoundError, RobotFileError, ScenarioError
from rcmplan.robot.arms import NEEDLE_AXES, needle_arm, needle_mount, roll_joint
from rcmplan.robot.home_search import HomeSearch, search_home
from rcmplan.robot.library import robots_dir, shipped_robot_files
from rcmplan.robot.needle import StraightNeedle
from rcmplan.robot.registry import ROBOTS, make_robot
from rcmplan.robot.robot_file import load_robot_file, model_chain, read_robot_file
from rcmplan.robot.urdf import load_urdf
from rcmplan.scene.scenario import load_scenario
from rcmplan.teleop.settings import TeleopSettings

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "docs" / "examples" / "kinova.toml"
KINOVA_URDF = "package://example-robot-data/kinova_description/robots/kinova.urdf"
# The homes the shipped arms had before they moved into robot files.
OLD_ARMS = {
    "ur5": ("ur_description/urdf/ur5_robot.urdf", "tool0",
            (0.0, -1.2, 1.9, -0.7, 0.5 * math.pi, 0.0)),
    "panda": ("panda_description/urdf/panda.urdf", "panda_link8",
              (0.0, -0.3, 0.0, -1.3, 0.0, 2.6, 0.25 * math.pi)),
}  # fmt: skip
KINOVA_HOME = "[-0.86, 2.85, 0.89, -1.46, 4.97, 0.0]"  # written by hand, near the searched one
# A 6-joint arm whose joints barely move (+-0.01 rad) holding its needle upright: no horizontal
# needle within its limits.
STIFF_URDF = "<robot name='stiff'><link name='base'/>{links}{joints}</robot>".format(
    links="".join(f"<link name='l{i}'/>" for i in range(1, 7)),
    joints="".join(
        f"<joint name='j{i}' type='revolute'><parent link='{'base' if i == 1 else f'l{i - 1}'}'/>"
        f"<child link='l{i}'/><origin xyz='{0.1 if i % 2 else 0.0} 0 0.2'/><axis xyz='{ax}'/>"
        "<limit lower='-0.01' upper='0.01' velocity='1' effort='1'/></joint>"
        for i, ax in enumerate(("0 0 1", "0 1 0", "0 1 0", "1 0 0", "0 1 0", "0 0 1"), start=1)
    ),
)


def robot_toml(path: Path, **keys: str) -> Path:
    """A robot file for the Kinova Jaco 2 with `keys` (TOML values as text) changed; a key set
    to "" is left out."""
    table = {"name": '"kinova"', "urdf": f'"{KINOVA_URDF}"', "flange": '"j2s6s200_end_effector"',
             "needle_axis": '"+x"', **keys}  # fmt: skip
    path.write_text("[robot]\n" + "".join(f"{k} = {v}\n" for k, v in table.items() if v))
    return path


def inject(tmp_path: Path, robot: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, dict]:
    """`rcmplan inject --robot FILE --no-plots` (kinematic plant, pinv): exit code, summary."""
    out = tmp_path / "out"
    code = main(["inject", "--robot", str(robot), "--no-plots", "--json", "--out", str(out)])
    capsys.readouterr()
    return code, json.loads((out / "summary.json").read_text())


@pytest.mark.parametrize("name", sorted(OLD_ARMS))
def test_the_shipped_robot_files_load_to_the_arms_built_before(name: str) -> None:
    urdf, flange, home = OLD_ARMS[name]
    old = needle_arm(load_urdf(robots_dir() / urdf, flange, name=name), home, name)
    new = make_robot(name)
    for attr in ("base", "origins", "axes", "tip", "lower", "upper", "velocity", "prismatic"):
        assert np.array_equal(getattr(new.chain, attr), getattr(old.chain, attr)), attr
    assert np.array_equal(new.home, old.home)
    assert new.needle.length == old.needle.length
    bend = read_robot_file(shipped_robot_files()[name]).needle_bend
    assert np.array_equal(new.needle.mount, needle_mount("+z", bend=bend))
    assert np.array_equal(new.needle.mount[:, 2:], old.needle.mount[:, 2:])  # the same needle
    assert (new.name, new.roll_joint, new.active) == (old.name, old.roll_joint, old.active)
    assert new.singular_threshold == old.singular_threshold


def test_the_registry_lists_every_file_in_the_shipped_robot_folder() -> None:
    folder = ROOT / "src" / "rcmplan" / "robots"
    stems = sorted(p.stem for p in folder.glob("*.toml"))
    assert list(ROBOTS) == ["iramis", *stems]
    for stem, path in shipped_robot_files().items():
        assert read_robot_file(path).name == stem
        assert ROBOTS[stem] == read_robot_file(path).description != ""


def test_pyproject_ships_the_robot_files_as_package_data() -> None:
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "robots/*.toml" in data["tool"]["setuptools"]["package-data"]["rcmplan"]


@pytest.mark.parametrize("axis", NEEDLE_AXES)
def test_the_needle_mount_is_a_rotation_whose_z_axis_is_the_needle_axis(axis: str) -> None:
    M = needle_mount(axis)
    z = np.zeros(3)
    z["xyz".index(axis[1])] = float(axis[0] + "1")
    assert np.array_equal(M[:3, 2], z)
    assert np.allclose(M[:3, :3].T @ M[:3, :3], np.eye(3), atol=0)
    assert np.linalg.det(M[:3, :3]) == pytest.approx(1.0, abs=1e-15)
    assert np.array_equal(M[:3, 3], np.zeros(3))


@pytest.mark.parametrize("bend", ["+x", "-y", "-x", (1.0, 1.0, 0.0), (0.3, -2.0, 0.5)])
def test_the_needle_bend_is_the_mounts_x_axis_normal_to_the_needle(bend) -> None:
    M = needle_mount("+z", bend=bend)
    b = np.zeros(3) if isinstance(bend, str) else np.array(bend)
    if isinstance(bend, str):
        b["xyz".index(bend[1])] = float(bend[0] + "1")
    b[2] = 0.0  # made normal to the needle (+z)
    np.testing.assert_allclose(M[:3, 0], b / np.linalg.norm(b), atol=1e-15)
    assert np.array_equal(M[:3, 2], [0.0, 0.0, 1.0])
    assert np.linalg.det(M[:3, :3]) == pytest.approx(1.0, abs=1e-15)


def test_a_needle_bend_only_turns_a_curved_needle_about_its_own_axis(tmp_path) -> None:
    """needle_bend leaves the straight needle where it was and turns the arc about the shaft:
    the tip of a curved needle moves to the side the file names."""
    home = {"home": KINOVA_HOME}
    plain = load_robot_file(robot_toml(tmp_path / "a.toml", **home)).arm
    bent = load_robot_file(robot_toml(tmp_path / "b.toml", needle_bend='"+y"', **home)).arm
    q = bent.home
    for lam in (0.0, 1.0):
        assert np.array_equal(bent.needle_point(q, lam), plain.needle_point(q, lam))
    assert np.array_equal(bent.needle.mount[:3, 0], [0.0, 1.0, 0.0])
    curved = load_scenario("curved").needle.fit(bent)
    a = bent.needle_axis(q)
    side = curved.tip(q) - bent.tip(q)  # the arc beyond the shaft's end
    side -= (side @ a) * a
    flange = bent.tool_pose(q)[:3, :3] @ bent.needle.mount[:3, :3].T
    np.testing.assert_allclose(side / np.linalg.norm(side), flange[:, 1], atol=1e-12)


def test_a_file_with_a_home_runs_the_default_injection_to_status_ok(tmp_path, capsys) -> None:
    path = robot_toml(tmp_path / "k.toml", home=KINOVA_HOME)
    code, summary = inject(tmp_path, path, capsys)
    assert code == 0
    assert (summary["status"], summary["robot"], summary["method"]) == ("ok", "kinova", "pinv")
    assert summary["plant"] == "kinematic"
    assert summary["robot_file"] == str(path.resolve())  # where the run's robot was read from


def test_a_file_without_a_home_runs_the_default_injection_to_status_ok(tmp_path, capsys) -> None:
    out = tmp_path / "out"
    code = main(["inject", "--robot", str(EXAMPLE), "--no-plots", "--json", "--out", str(out)])
    err = capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert code == 0
    assert (summary["status"], summary["robot"]) == ("ok", "kinova")
    home = load_robot_file(EXAMPLE).arm.home
    said = f"robot kinova: no home in {EXAMPLE}; chose home = [{float(home[0])!r}, "
    assert said in err and "manipulability" in err
    # the line as printed, pasted into the file, gives the same pose to the bit
    line = "home = " + err.split("chose home = ", 1)[1].split(" (rad;", 1)[0]
    pinned = tmp_path / "pinned.toml"
    pinned.write_text(EXAMPLE.read_text() + line + "\n")
    kept = load_robot_file(pinned)
    assert not kept.home_searched
    assert kept.arm.home.tolist() == home.tolist()


def test_the_searched_home_is_horizontal_within_the_limits_and_away_from_the_arm() -> None:
    loaded = load_robot_file(EXAMPLE)
    arm = loaded.arm
    assert loaded.home_searched
    axis = arm.needle_axis(arm.home)
    assert np.allclose(axis, [-1.0, 0.0, 0.0], rtol=0, atol=1e-9)  # placed: along -x
    pad = 0.1 * (arm.upper - arm.lower)
    assert np.all(arm.home >= arm.lower + pad - 1e-12)
    assert np.all(arm.home <= arm.upper - pad + 1e-12)
    tip = arm.tip(arm.home) - arm.chain.base[:3, 3]
    assert axis[:2] @ tip[:2] / np.linalg.norm(tip[:2]) >= math.cos(math.pi / 6) - 1e-9
    assert tip[2] >= 0.0
    assert loaded.measure == arm.singularity_measure(arm.home) >= HomeSearch().min_measure


def test_a_searched_home_is_kept_between_processes_equal_to_the_bit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from rcmplan.robot import robot_file

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setattr(robot_file, "_SEARCHED", {})
    first = load_robot_file(EXAMPLE).arm.home
    (kept,) = (tmp_path / "cache" / "rcmplan" / "home").glob("*.json")

    def no_search(*args: object) -> None:
        raise AssertionError("searched again")

    monkeypatch.setattr(robot_file, "search_home", no_search)
    monkeypatch.setattr(robot_file, "_SEARCHED", {})  # as in a new process
    np.testing.assert_array_equal(load_robot_file(EXAMPLE).arm.home, first)
    with pytest.raises(AssertionError, match="searched again"):  # other settings: a search
        load_robot_file(EXAMPLE, HomeSearch(seed=1))
    for broken in ("{", '{"q": [1.0], "measure": 0.1, "tried": [512, 8]}'):  # one joint of six
        kept.write_text(broken)
        monkeypatch.setattr(robot_file, "_SEARCHED", {})
        with pytest.raises(AssertionError, match="searched again"):
            load_robot_file(EXAMPLE)


def test_the_home_search_is_deterministic_and_beats_the_hand_written_homes() -> None:
    ur5 = make_robot("ur5")
    chain = load_urdf(robots_dir() / OLD_ARMS["ur5"][0], "tool0", name="ur5")
    first = search_home(chain, ur5.needle, 5)
    again = search_home(chain, ur5.needle, 5)
    assert first.q is not None and again.q is not None
    assert np.array_equal(first.q, again.q)
    assert first.measure > ur5.singularity_measure(ur5.home)


def test_the_last_joint_is_the_needle_roll_only_when_the_needle_lies_on_its_axis() -> None:
    chain = model_chain(read_robot_file(EXAMPLE))
    assert roll_joint(chain, StraightNeedle(0.06, needle_mount("+x"))) == chain.n - 1
    assert roll_joint(chain, StraightNeedle(0.06, needle_mount("+z"))) is None


def test_a_relative_model_path_is_found_from_the_robot_file(tmp_path: Path) -> None:
    (tmp_path / "arm.urdf").write_bytes((robots_dir() / KINOVA_URDF.split("/", 3)[3]).read_bytes())
    arm = load_robot_file(robot_toml(tmp_path / "k.toml", urdf='"arm.urdf"', home=KINOVA_HOME)).arm
    assert arm.chain.n == 6 and arm.name == "kinova"


def test_an_mjcf_robot_file_of_the_ur5_holds_the_ur5s_needle(tmp_path: Path) -> None:
    pytest.importorskip("mujoco", reason="the MJCF is written by rcmplan's MuJoCo arm model")
    from rcmplan.sim.mujoco.arm_model import arm_xml

    ur5 = make_robot("ur5")
    (tmp_path / "ur5.xml").write_text(arm_xml(ur5))  # the needle's base is the site needle_base
    (tmp_path / "m.toml").write_text(
        '[robot]\nname = "ur5-mjcf"\nmjcf = "ur5.xml"\n'
        f'flange = "needle_base"\nhome = {ur5.home.tolist()}\n'
    )
    arm = load_robot_file(tmp_path / "m.toml").arm
    assert (arm.name, arm.roll_joint) == ("ur5-mjcf", 5)
    for q in (ur5.home, ur5.home + 0.1):
        assert np.allclose(arm.tip(q), ur5.tip(q), rtol=0, atol=1e-10)  # the XML rounds
        assert np.allclose(arm.needle_axis(q), ur5.needle_axis(q), rtol=0, atol=1e-10)


def test_a_scenario_names_a_robot_file_relative_to_itself(tmp_path: Path) -> None:
    robot_toml(tmp_path / "k.toml", home=KINOVA_HOME)
    (tmp_path / "s.toml").write_text('name = "k"\nrobot = "k.toml"\n')
    assert load_scenario(tmp_path / "s.toml").robot == str(tmp_path / "k.toml")
    (tmp_path / "bad.toml").write_text('robot = "missing.toml"\n')
    with pytest.raises(ScenarioError, match=r"missing\.toml"):
        load_scenario(tmp_path / "bad.toml")


def test_teleop_settings_and_scenarios_take_a_robot_file(tmp_path: Path) -> None:
    path = str(robot_toml(tmp_path / "k.toml", home=KINOVA_HOME))
    assert TeleopSettings(robot=path).robot == path
    assert load_scenario("default").with_robot(path).robot == path
    with pytest.raises(InvalidInputError, match=r"iramis, panda, ur5, or a robot file"):
        load_scenario("default").with_robot("kuka")


def test_robot_prints_a_robot_file_arm(tmp_path, capsys) -> None:
    path = robot_toml(tmp_path / "k.toml", home=KINOVA_HOME)
    assert main(["robot", "--robot", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["robot"] == "kinova" and len(doc["joints"]) == 6
    assert main(["robot", "--robot", str(path)]) == 0  # the file named, having no description
    assert capsys.readouterr().out.splitlines()[0] == f"kinova: from {path}"
    robot_toml(path, home=KINOVA_HOME, description='"Kinova Jaco 2"')
    assert main(["robot", "--robot", str(path)]) == 0
    assert capsys.readouterr().out.splitlines()[0] == f"kinova: Kinova Jaco 2 ({path})"


@pytest.mark.parametrize(
    ("text", "said"),
    [("[robt]\nname = 'x'\n", "tables = ('robt') is invalid; valid: one [robot] table; did "
                                "you mean robot?"),
     ("", "tables = () is invalid; valid: one [robot] table")],
)  # fmt: skip
def test_a_file_without_its_robot_table_says_which_tables_it_has(tmp_path, text, said) -> None:
    path = tmp_path / "arm.toml"
    path.write_text(text)
    with pytest.raises(RobotFileError) as info:
        load_robot_file(path)
    assert str(info.value) == f"robot file {str(path)!r}: {said}"


def test_a_missing_or_malformed_file_is_named_once_with_what_is_wrong(tmp_path) -> None:
    missing, broken = tmp_path / "nowhere.toml", tmp_path / "broken.toml"
    broken.write_text("[robot\n")
    with pytest.raises(RobotFileError) as info:
        load_robot_file(missing)
    assert str(info.value) == (f"robot file {str(missing)!r}: path = {str(missing)!r} is "
                               "invalid; valid: a readable file (No such file or directory)")  # fmt: skip
    with pytest.raises(RobotFileError, match=r": text = 'not TOML' is invalid; valid: UTF-8 TOML"):
        load_robot_file(broken)


def test_an_unknown_robot_or_a_missing_file_is_refused_by_the_option(capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["inject", "--robot", "no-such-arm.toml", "--no-plots"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "iramis, panda, ur5, or a robot file" in err
    assert f"there is no file {str(Path('no-such-arm.toml').absolute())!r}" in err


BAD = {  # case: (keys changed, error type, what the message names)
    "missing key": ({"flange": ""}, RobotFileError, r"\[robot\] flange = 'missing'"),
    "unknown key": ({"flang": '"x"'}, RobotFileError,
                    r"\[robot\] key = 'flang' is invalid.*needle_axis.*; did you mean flange\?$"),
    "urdf that does not load": ({"urdf": '"broken.urdf"'}, RobotFileError,
                                r"\[robot\] urdf = .*broken\.urdf.*malformed XML"),
    "missing urdf": ({"urdf": '"nowhere.urdf"'}, RobotFileError, r"no file at .*nowhere\.urdf"),
    "flange not in the file": ({"flange": '"tool0"'}, RobotFileError,
                               r"flange = 'tool0'.*one of .*j2s6s200_link_6"),
    "flange misspelt": ({"flange": '"j2s6s200_end_efector"'}, RobotFileError,
                        r"flange = 'j2s6s200_end_efector'.*; did you mean j2s6s200_end_effector\?"),
    "needle axis": ({"needle_axis": '"z"'}, RobotFileError, r"needle_axis = 'z'.*\+x -x \+y"),
    "needle axis zero": ({"needle_axis": "[0, 0, 0]"}, RobotFileError,
                         r"needle_axis = \(0, 0, 0\).*non-zero direction"),
    "needle back into its link": ({"needle_axis": '"-x"'}, RobotFileError,
                                  r"needle_axis = '-x'.*j2s6s200_joint_6 to the flange: "
                                  r"\(1\.000, 0\.000, 0\.000\).*nearest '\+x'.*180 degrees"),
    "needle bend": ({"needle_bend": '"y"'}, RobotFileError, r"needle_bend = 'y'.*\+x -x \+y"),
    "needle bend along the needle": ({"needle_bend": "[-1, 0, 0.1]"}, RobotFileError,
                                     r"needle_bend = .*25 degrees from the needle's line"),
    "needle offset": ({"needle_offset_mm": "[0, 25]"}, RobotFileError,
                      r"needle_offset_mm = \(0, 25\).*\[x, y, z\]"),
    "home outside the limits": ({"home": "[1.5707, 2.618, -1.5707, 3.1415, 2.618, 0.0]"},
                                RobotFileError,
                                r"home\[2\] \(joint 'j2s6s200_joint_3'\) = -1\.5707.*"
                                r"\[0\.331613, 5\.95157\] rad"),
    "needle vertical at home": ({"home": "[0.0, 3.14159, 3.14159, 0.0, 3.14159, 0.0]"},
                                RobotFileError, r"home = .*not vertical"),
    "home count": ({"home": "[0.0, 3.0]"}, RobotFileError, r"home = '2 values'.*6 values"),
    "too few joints": ({"flange": '"j2s6s200_link_4"'}, RobotFileError,
                       r"at least 5 joints moving the needle.*\(4 do: j2s6s200_joint_1"),
    "no home found": ({"urdf": '"stiff.urdf"', "flange": '"l6"', "needle_axis": '"+z"'},
                      NoHomeFoundError, r"home = 'absent'.*no pose within the joint limits.*"
                      r"512 samples, 8 refined; none met the conditions"),
}  # fmt: skip


def bad_file(tmp_path: Path, case: str) -> Path:
    (tmp_path / "broken.urdf").write_text("<robot name='x'><link name='a'></robot>")
    (tmp_path / "stiff.urdf").write_text(STIFF_URDF)
    return robot_toml(tmp_path / "bad.toml", **BAD[case][0])


CASES = [pytest.param(c, marks=heavy) if c == "no home found" else c for c in sorted(BAD)]


@pytest.mark.parametrize("case", CASES)
def test_a_bad_robot_file_raises_its_typed_error_naming_the_fault(tmp_path, case: str) -> None:
    path = bad_file(tmp_path, case)
    with pytest.raises(BAD[case][1], match=BAD[case][2]) as exc:
        load_robot_file(path)
    assert exc.value.path == path and str(path) in str(exc.value)


@pytest.mark.parametrize("case", CASES)
def test_a_bad_robot_file_stops_inject_with_exit_2_and_its_status(tmp_path, capsys, case) -> None:
    code, summary = inject(tmp_path, bad_file(tmp_path, case), capsys)
    assert code == 2
    assert summary["status"] == BAD[case][1].status
    assert summary["message"].startswith(BAD[case][1].__name__)
    assert not (tmp_path / "out" / "log.npz").exists()  # refused before any motion


def test_a_needle_with_its_own_direction_and_offset_on_the_flange(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    """needle_axis as a direction gives the named axis's robot; needle_offset_mm moves the
    needle's base in the flange frame (its axis unchanged), and the arm runs the default
    injection with the RCM held."""
    home = {"home": KINOVA_HOME}
    named = load_robot_file(robot_toml(tmp_path / "a.toml", **home)).arm
    vector = load_robot_file(robot_toml(tmp_path / "b.toml", needle_axis="[2, 0, 0]", **home)).arm
    np.testing.assert_allclose(vector.tip(vector.home), named.tip(named.home), atol=1e-12)
    path = robot_toml(tmp_path / "c.toml", needle_offset_mm="[0, 0, 25]", **home)
    moved = load_robot_file(path).arm
    base = moved.needle_point(moved.home, 0.0) - named.needle_point(named.home, 0.0)
    assert np.linalg.norm(base) == pytest.approx(25e-3, abs=1e-12)
    np.testing.assert_allclose(moved.needle_axis(moved.home), named.needle_axis(named.home),
                               atol=1e-12)  # fmt: skip
    code, summary = inject(tmp_path, path, capsys)
    assert code == 0 and summary["status"] == "ok"
    assert summary["max_rcm_deviation_m"] <= 1e-6


def test_a_needle_pointing_back_is_loaded_when_its_offset_places_it_off_the_link(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The back-into-the-link refusal holds for a needle at the flange's origin only: with
    needle_offset_mm the user has placed it, and the file loads with the needle as given."""
    keys = {"needle_axis": '"-x"', "needle_offset_mm": "[0, 40, 0]", "home": KINOVA_HOME}
    mount = load_robot_file(robot_toml(tmp_path / "k.toml", **keys)).arm.needle.mount
    assert mount[:3, 2].tolist() == [-1.0, 0.0, 0.0] and mount[:3, 3].tolist() == [0, 0.04, 0]


COMMANDS = [["sweep", "--targets", "2", "--no-plots"], ["render", "--frames", "2"],
            ["compare", "--method", "pinv", "--no-plots"], ["teleop", "--no-plots"],
            ["subretinal", "--hover-s", "0.2", "--hold-s", "0.2", "--no-plots"]]  # fmt: skip


@pytest.mark.parametrize("command", COMMANDS, ids=[c[0] for c in COMMANDS])
def test_every_command_taking_a_robot_file_says_its_home_and_names_it_in_its_summary(
    tmp_path, capsys, command
) -> None:  # type: ignore[no-untyped-def]
    """On stderr the searched home; in summary.json the robot's name and the file's path, the
    same two fields on every command (`registry.summary_fields`)."""
    if command[0] == "render":
        pytest.importorskip("mujoco", reason="render draws with MuJoCo (extra `mujoco`)")
    out = tmp_path / "out"
    assert main([*command, "--robot", str(EXAMPLE), "--out", str(out)]) == 0
    home = load_robot_file(EXAMPLE).arm.home
    assert f"rcmplan {command[0]}: robot kinova: no home in {EXAMPLE}; chose home = [" \
           f"{float(home[0])!r}, " in capsys.readouterr().err  # fmt: skip
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["robot"], summary["robot_file"]) == ("kinova", str(EXAMPLE.resolve()))


def test_the_home_note_names_the_joints_in_metres(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """TIAGo's arm from example-robot-data rises on a prismatic torso joint: the home the
    command states is in rad but for that joint, in m."""
    path = tmp_path / "tiago.toml"
    path.write_text('[robot]\nname = "tiago"\nflange = "arm_tool_link"\nneedle_axis = "+x"\n'
                    'urdf = "package://example-robot-data/tiago_description/robots/tiago.urdf"\n'
                    "home = [0.27, 0.86, -0.53, -0.93, 1.75, 0.64, 1.13, 0.0]\n")  # fmt: skip
    loaded = load_robot_file(path)
    assert loaded.arm.chain.prismatic.tolist() == [True] + [False] * 7
    assert "robot tiago: home = [0.27, 0.86, " in loaded.note()
    assert "(rad, m for torso_lift_joint; manipulability" in loaded.note()


def test_a_curved_needle_on_an_arm_that_cannot_roll_it_names_the_axis_that_would(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The Jaco's last joint turns about its flange's x (the link's outward direction): with
    the needle along the flange's z nothing rolls it, and the refusal says which axis does."""
    keys = {"needle_axis": '"+z"', "home": "[0.43, 2.13, 4.82, 0.54, 1.05, 1.80]"}
    arm = load_robot_file(robot_toml(tmp_path / "k.toml", **keys)).arm
    assert arm.roll_joint is None
    with pytest.raises(
        InvalidInputError,
        match=r"robot = 'kinova'.*j2s6s200_joint_6, turns "
        r"about the flange's x axis: needle_axis = \"\+x\" in the robot file",
    ):
        load_scenario("curved").needle.fit(arm)


def test_the_live_view_says_which_home_it_searched(capsys) -> None:  # type: ignore[no-untyped-def]
    from argparse import Namespace

    from rcmplan.cli.view import checked_source

    args = Namespace(live=True, scale=1.0, scenario="default", robot=str(EXAMPLE),
                     plant="kinematic", no_realtime=True, filter="none")  # fmt: skip
    assert checked_source(args).robot.name == "kinova"
    assert f"rcmplan view: robot kinova: no home in {EXAMPLE}; chose home = [" in (
        capsys.readouterr().err
    )
