"""Generated inputs to the plants, the eye, the procedures and the scenarios (the rule:
tests/api_inputs.py): a typed error naming the argument, or a finite result within bounds."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

import rcmplan as rp
from rcmplan.control.phase import MAX_TARGETS

from api_inputs import (
    JUNK,
    Arg,
    choice,
    examples,
    fields_finite,
    finite,
    names_or_junk,
    number,
    one_bad,
    optional,
    probe,
    shaped,
    vector,
)

ROBOT = rp.Iramis()
UR5 = rp.make_robot("ur5")
EYE = rp.default_eye(ROBOT)
POINTS = rp.default_points(EYE)
SCENARIO = rp.load_scenario("default")
robots = choice([ROBOT, None], ["iramis", 3])
sliders = Arg(st.one_of(vector(6, -0.01, 0.01).good, vector(6, -0.05, 0.05).good),
              vector(6, -0.01, 0.01).bad)  # fmt: skip


def at_rest(plant: Any) -> bool:
    return 0 < plant.dt <= 1.0 and finite(plant.read_actuators())


@examples(250)
@given(args=one_bad(robots, number(1e-4, 0.1), sliders))
def test_kinematic_plants_are_built_and_commanded_or_refused(args: tuple[Any, ...]) -> None:
    robot, dt, s = args
    plant = probe("KinematicPlant", rp.KinematicPlant, robot, dt, names=("robot", "dt"), ok=at_rest)
    if plant is None:
        return
    done = lambda v: v is None  # noqa: E731
    probe("KinematicPlant.command_actuators", plant.command_actuators, s, names=("s",), ok=done)
    plant.advance()
    assert finite(plant.read_actuators()) and math.isfinite(plant.time)
    probe("KinematicPlant.reset", plant.reset, s, names=("s",), ok=done)


MUJOCO = ("robot", "mode", "dt", "physics_dt", "gravity_compensation", "eye", "points", "piezo",
          "gap_limit", "needle_arc")  # fmt: skip


@examples(40)
@given(args=one_bad(
    choice([None, ROBOT], [UR5, "iramis"]), choice(["kinematic"], ["x", "Dynamic"]),
    choice([1e-3, 2e-3], [0.0, -1e-3, 2.0, "x"]), choice([1e-4, 5e-4], [0.0, 3e-4, -1e-4, "x"]),
    Arg(st.booleans(), JUNK),
    choice([None, EYE], ["eye"]), choice([None], ["points"]), choice([None], ["piezo"]),
    number(1e-6, 1e-3), optional(vector(2, 0.001, 0.3)),
))  # fmt: skip
def test_mujoco_plants_are_built_or_refused(args: tuple[Any, ...]) -> None:
    plant = probe("MujocoPlant", rp.MujocoPlant, *args, names=MUJOCO, ok=at_rest)
    if plant is not None:
        probe("MujocoPlant.command_actuators", plant.command_actuators, [0.0, 0, 0, 0, 0, "x"],
              names=("s",))  # fmt: skip


ARM = ("robot", "mode", "dt", "physics_dt", "eye", "points", "servo", "needle_arc")


@examples(30)
@given(args=one_bad(
    choice([UR5], [ROBOT, "ur5", None]), choice(["kinematic"], ["x", "Dynamic"]),
    choice([1e-3, 2e-3], [0.0, -1e-3, 2.0, "x"]), choice([1e-4, 5e-4], [0.0, 3e-4, -1e-4, "x"]),
    choice([None], ["eye", 3]), choice([None], ["points"]), choice([None], ["servo", 1.0]),
    optional(vector(2, 0.001, 0.3)),
))  # fmt: skip
def test_arm_plants_and_their_scenes_are_built_or_refused(args: tuple[Any, ...]) -> None:
    """`ArmPlant` (an arm's MuJoCo plant) with a curved needle's arc or bad input: a typed error
    naming the argument, or a plant at rest whose scene a camera sees (two cameras)."""
    from rcmplan.sim.mujoco.arm_plant import ArmPlant

    plant = probe("ArmPlant", ArmPlant, *args, names=ARM, ok=at_rest)
    if plant is not None:
        probe("ArmPlant.scene", plant.scene, ok=lambda md: md[0].ncam == 2)


@examples(150)
@given(args=one_bad(choice(["kinematic", "mujoco-kinematic"], ["x"]), robots,
                    choice([None, {"eye": EYE}, EYE], ["eye", {"eye": 1}]),
                    choice([{}, {"dt": 2e-3}], [{"dt": "x"}, {"speed": 1}])))  # fmt: skip
def test_plants_by_name_are_built_or_refused(args: tuple[Any, ...]) -> None:
    name, robot, scene, extra = args
    extra = extra if isinstance(extra, dict) else {"dt": extra}
    probe("make_plant", rp.make_plant, name, robot, scene, **extra, ok=at_rest,
          names=("plant", "name", "robot", "scene", "eye", "dt", "kwargs", *extra))  # fmt: skip


@st.composite
def eyes(draw: st.DrawFn) -> tuple[Any, ...]:
    """(center, radius, wall, trocar, trocar_radius): a valid eye with at most one bad value."""
    center = draw(st.lists(st.floats(-0.2, 0.2), min_size=3, max_size=3).map(np.array))
    radius = draw(st.floats(5e-3, 0.02))
    direction = draw(st.sampled_from([(1, 0, 0), (0, 0.6, 0.8), (-0.48, 0.6, 0.64)]))
    args = [center, radius, 1e-3, center + radius * np.array(direction), 0.45e-3]
    i = draw(st.integers(-1, 4))
    if i >= 0:
        args[i] = draw([vector(3, -0.2, 0.2).bad, number(1e-3, 0.05).bad, number(0, 1e-3).bad,
                        st.one_of(st.none(), vector(3, -0.2, 0.2).any()), number(1e-4, 5e-3).bad][i])  # fmt: skip
    return tuple(args)


@examples(250)
@given(args=eyes(), data=st.data())
def test_eyes_are_finite_or_refused(args: tuple[Any, ...], data: st.DataObject) -> None:
    eye = probe("Eye", rp.Eye, *args, ok=fields_finite,
                names=("center", "radius", "wall", "trocar", "trocar_radius"))  # fmt: skip
    if eye is None:
        return
    inside = st.lists(st.floats(-0.3, 0.3), min_size=3, max_size=3).map(lambda d: eye.axis + d)
    p = data.draw(
        Arg(inside.map(lambda d: eye.center + 0.5 * eye.radius * d), vector(3, -1, 1).bad).any()
    )
    direction = data.draw(Arg(inside, vector(3, -1.0, 1.0).bad).any())
    probe("Eye.distance_to_retina", eye.distance_to_retina, p, ok=finite, names=("p",))
    probe("Eye.retina_point", eye.retina_point, direction, names=("direction",),
          ok=lambda r: shaped((3,))(r) and abs(eye.distance_to_retina(r)) < 1e-9)  # fmt: skip


EYE_ARGS = ("robot", "radius", "wall", "trocar_radius", "trocar_offset", "insertion_angles",
            "eye", "outside", "depth", "spread")  # fmt: skip


@examples(250)
@given(args=one_bad(
    choice([ROBOT, UR5, None], ["ur5"]), number(5e-3, 0.02), number(1e-4, 3e-3),
    number(1e-4, 2e-3), vector(3, -0.02, 0.02), vector(2, -1.0, 1.0), number(1e-3, 0.03),
    number(1e-3, 0.01), number(0.0, 0.3),
))  # fmt: skip
def test_default_eyes_and_points_are_finite_or_refused(args: tuple[Any, ...]) -> None:
    *eye_args, outside, depth, spread = args
    eye = probe("default_eye", rp.default_eye, *eye_args, ok=fields_finite, names=EYE_ARGS)
    probe("default_points", rp.default_points, eye if eye is not None else eye_args[0],
          outside, depth, spread, names=EYE_ARGS,
          ok=lambda pts: all(shaped((3,))(v) for v in pts.as_dict().values())
          and np.allclose(pts.p2, eye.port))  # fmt: skip


def bounded_steps(s: Any) -> bool:
    return fields_finite(s) and 0 < s.position <= 5e-3 and 0 < s.angle <= 0.1


@examples(250)
@given(args=one_bad(number(1e-5, 5e-3), number(1e-4, 0.1), number(0.0, 0.05), number(0.0, 1.0)))
def test_step_sizes_and_counts_are_bounded_or_refused(args: tuple[Any, ...]) -> None:
    position, angle, distance, turn = args
    steps = probe("Steps", rp.Steps, position, angle, names=("position", "angle"), ok=bounded_steps)
    if steps is not None:
        probe("Steps.count", steps.count, distance, turn, ok=lambda n: 1 <= n <= MAX_TARGETS,
              names=("distance", "angle"))  # fmt: skip


def planned(phases: Any) -> bool:
    return len(phases) >= 3 and all(callable(p.targets) or finite(p.targets) for p in phases)


PROCEDURE = ("offset", "radius", "turns", "pitch", "points_per_turn", "robot", "eye", "points",
             "shape", "steps", "visits", "p3")  # fmt: skip


@examples(120)
@given(args=one_bad(
    vector(2, -1e-3, 1e-3), number(1e-4, 2e-3), number(0.1, 2.0), number(-1e-3, 1e-3),
    Arg(st.integers(8, 200), st.one_of(st.integers(-1, 7), st.just(10**9), JUNK)),
    choice([ROBOT], [None, UR5.chain]), choice([EYE], [None, "eye"]), choice([POINTS], [None, EYE]),
    choice([None, rp.Steps(), rp.Steps(1e-3, 0.05)], ["steps"]),
    choice([("p4",), ("p4", "p7"), ()], [("p1",), [1], ("p4", "p9")]),
))  # fmt: skip
def test_procedures_are_planned_or_refused(args: tuple[Any, ...]) -> None:
    *shape_args, robot, eye, points, steps, visits = args
    shape = probe("Spiral", rp.Spiral, *shape_args, ok=fields_finite, names=PROCEDURE)
    if shape is not None:
        probe("Spiral.path", shape.path, eye, POINTS.p3, names=PROCEDURE,
              ok=lambda path: finite(path) and path.shape[1] == 3)  # fmt: skip
        probe("spiral", rp.spiral, robot, eye, points, shape, steps, ok=planned, names=PROCEDURE)
    probe("injection", rp.injection, robot, eye, points, steps, visits, ok=planned, names=PROCEDURE)


def ran_ok(result: Any) -> bool:
    return result.status == "ok" and result.log.max_rcm_deviation() < 1e-6


@examples(60)
@given(args=one_bad(
    choice([SCENARIO], ["default", None]), choice([None, ROBOT], ["iramis", UR5.chain]),
    choice([None, lambda phase: None], ["x", 3]),
    Arg(st.sampled_from(["default", "spiral"]), st.one_of(names_or_junk(), st.just("none.toml"))),
))  # fmt: skip
def test_scenarios_are_loaded_and_run_or_refused(args: tuple[Any, ...]) -> None:
    scenario, robot, on_phase, source = args
    probe("load_scenario", rp.load_scenario, source, ok=lambda s: isinstance(s.name, str),
          names=("scenario", "source"))  # fmt: skip
    probe("run_scenario", rp.run_scenario, scenario, robot, on_phase, ok=ran_ok,
          names=("scenario", "robot", "on_phase"))  # fmt: skip
