"""Generated inputs to the controller, its solvers, tasks, limits, targets and phases (the rule:
tests/api_inputs.py): a typed error naming the argument, or a finite result within bounds."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

import rcmplan as rp
from rcmplan.control.phase import MAX_TARGETS, interpolate
from rcmplan.control.qp_limits import QpLimits
from rcmplan.control.targets import pivot_target, tip_of_target

from api_inputs import (
    BAD_SCALARS,
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

ROBOT = rp.Iramis()
UR5 = rp.make_robot("ur5")
EYE = rp.default_eye(ROBOT)
INSERT = rp.injection(ROBOT, EYE, rp.default_points(EYE))[2].targets  # (N, 6) X_ext targets
TIP = ROBOT.tip(ROBOT.home)
QP = rp.QpSolver(ROBOT, EYE)
SOLVERS = [rp.PinvSolver(), rp.DlsSolver(), rp.TipSolver(), rp.TipSolver(1e-4), QP]
LOG = rp.Controller(rp.KinematicPlant(ROBOT), rp.PinvSolver()).run(
    [rp.Phase("move", np.array([TIP + [1e-4, 0, 0], TIP + [2e-4, 0, 0]]), "free")]
)


def _with_bad_entry(row: np.ndarray, i: int, bad: Any) -> list[Any]:
    out: list[Any] = row.tolist()
    out[i] = bad
    return out


targets = Arg(
    st.one_of(st.sampled_from(list(INSERT)), st.sampled_from(INSERT.tolist())),
    st.one_of(
        st.builds(_with_bad_entry, st.sampled_from(list(INSERT)), st.integers(0, 5), BAD_SCALARS),
        vector(6, -0.2, 0.2).bad, st.just([0.0]), st.just(0.1), st.just(INSERT[:2]),
    ),
)  # fmt: skip
tip_targets = Arg(st.sampled_from([TIP + [1e-4, 0, 0], [*TIP]]), vector(3, -0.2, 0.2).bad)
joints = Arg(
    st.lists(st.floats(-0.01, 0.01), min_size=6, max_size=6).map(np.array),
    vector(6, -0.5, 0.5).bad,
)
lams = number(0.0, 1.0)
errors = {"rcm": optional(vector(6, -1e-3, 1e-3)), "free": optional(vector(3, -1e-3, 1e-3))}


POSES = [rp.solve_pose(ROBOT, t) for t in INSERT]  # the needle through the trocar
states = st.tuples(st.integers(0, len(POSES) - 2), st.floats(-1e-7, 1e-7)).map(
    lambda a: (POSES[a[0]].q + a[1], POSES[a[0]].lam, INSERT[a[0] + 1])
)


@examples(250)
@given(solver=st.sampled_from(SOLVERS), data=st.data())
def test_solver_errors_and_steps_are_finite_or_refused(solver: Any, data: st.DataObject) -> None:
    name = type(solver).__name__
    free = solver.kind == "free"
    q0, lam0, target0 = data.draw(states)
    q, lam, target, error = data.draw(one_bad(
        Arg(st.none(), joints.bad), Arg(st.none(), lams.bad),
        Arg(st.none(), (tip_targets if free else targets).bad), errors[solver.kind],
    ))  # fmt: skip
    q = q0 if q is None else q
    lam = lam0 if lam is None else lam
    target = (target0[3:] if free else target0) if target is None else target
    e = probe(f"{name}.error", solver.error, ROBOT, q, lam, target, ok=shaped((3 if free else 6,)),
              names=("q", "lam", "target"))  # fmt: skip
    step = lambda r: len(r) == 2 and shaped((5,))(r[0]) and math.isfinite(r[1])  # noqa: E731
    probe(f"{name}.step", solver.step, ROBOT, q, lam, target, e if error is None else error,
          ok=step, names=("q", "lam", "target", "error"))  # fmt: skip


tolerances = choice([None, rp.Tolerance(), rp.Tolerance(1e-7, 1e-6)], [(1e-8, 1e-7), "x", 1e-8])


@examples(300)
@given(args=one_bad(vector(6, 0.1, 1.9), number(1e-6, 1e-2), number(1e-12, 1e-4),
                    number(1e-12, 1e-3), choice(["exact", "thesis"], ["x", "Exact"]),
                    number(0.0, 1.0), tolerances))  # fmt: skip
def test_solver_constructors_accept_only_finite_bounded_settings(args: tuple[Any, ...]) -> None:
    K, damping, pos, ang, variant, gain, tol = args
    tolerance = probe("Tolerance", rp.Tolerance, pos, ang, names=("position", "angle"),
                      ok=lambda t: fields_finite(t) and t.position > 0 and t.angle > 0)  # fmt: skip
    if tolerance is not None:
        probe("Tolerance.x_ext", tolerance.x_ext, ok=shaped((6,)))
    tol_args = {} if tol is None else {"tol": tol}
    gains = lambda s: fields_finite(s) and np.all((np.asarray(s.K) > 0) & (np.asarray(s.K) < 2))  # noqa: E731
    probe("PinvSolver", rp.PinvSolver, K, variant, ok=gains, posture_gain=gain,
          names=("K", "variant", "posture_gain", "tol"), **tol_args)  # fmt: skip
    damped = lambda s: fields_finite(s) and 0 < s.damping < math.inf  # noqa: E731
    probe("DlsSolver", rp.DlsSolver, damping, ok=damped, names=("damping", "tol"), **tol_args)
    probe(
        "TipSolver", rp.TipSolver, damping, ok=fields_finite, names=("damping", "tol"), **tol_args
    )


QP_ARGS = (
    "robot",
    "eye",
    "dt",
    "K",
    "damping",
    "tol",
    "limits",
    "backend",
    "servo",
    "extra_limits",
)


@examples(150)
@given(args=one_bad(
    choice([ROBOT, UR5], [None, "iramis"]), choice([EYE, None], ["eye"]), number(1e-4, 1e-2),
    vector(6, 0.1, 1.9), number(1e-6, 1e-2), choice([None, rp.Tolerance()], ["x"]),
    choice([None, QpLimits()], [{}]), choice(["daqp"], ["nope", "DAQP"]),
    choice([None, rp.KinematicPlant(ROBOT)], ["plant"]), choice([()], [None, ("x",), 3]),
))  # fmt: skip
def test_qp_solvers_are_built_or_refused(args: tuple[Any, ...]) -> None:
    probe("QpSolver", rp.QpSolver, *args, ok=lambda s: finite(s.K) and s.dt > 0, names=QP_ARGS)


QP_FIELDS = ("rcm_tolerance", "travel_margin", "retina_margin", "eye_gain", "port_zone",
             "contact_tolerance", "singular_margin", "singular_gain", "angle_weight",
             "rcm_weight", "tip_speed")  # fmt: skip


@examples(200)
@given(name=st.sampled_from(QP_FIELDS), value=number(0.0, 1.0).any())
def test_qp_settings_are_finite_and_bounded_or_refused(name: str, value: Any) -> None:
    bounded = lambda v: v is None or (math.isfinite(v) and 0 <= v <= 1e6)  # noqa: E731
    probe("QpLimits", lambda: QpLimits(**{name: value}), names=(name,),
          ok=lambda lim: bounded(getattr(lim, name)))  # fmt: skip


TASKS = {
    "TipPosition": choice([(0, 1, 2), (1,), (0, 2), [2]], [(), (3,), (0, 0), (-1,), "xyz", (1.5,)]),
    "NeedleAngles": choice(["exact", "thesis"], ["x"]), "RcmPoint": None, "NeedleBase": None,
    "Posture": None,
}  # fmt: skip


@examples(250)
@given(task=st.sampled_from(list(TASKS)), robot=st.sampled_from([ROBOT, UR5]), data=st.data())
def test_tasks_are_finite_or_refused(task: str, robot: Any, data: st.DataObject) -> None:
    arg = TASKS[task]
    extra = (arg,) if arg is not None else ()
    values = data.draw(one_bad(joints, lams, *extra))
    q, lam = values[:2]
    t = probe(task, getattr(rp, task), *values[2:], names=("axes", "variant"))
    if t is None:
        return
    m = len(robot.active)
    probe(f"{task}.value", t.value, robot, q, lam, ok=finite, names=("q", "lam"))

    def rows(J: Any) -> bool:
        return isinstance(J, np.ndarray) and J.ndim == 2 and J.shape[1] in (m, m + 1) and finite(J)

    probe(f"{task}.jacobian", t.jacobian, robot, q, lam, ok=rows, names=("q", "lam"))


LIMITS = ("ActuatorLimit", "RcmLimit", "RetinaBarrier", "SingularMargin", "TipSpeed")


@examples(250)
@given(args=one_bad(vector(3, -0.2, 0.2), matrix(np.eye(3)), vector(3, -0.02, -0.001),
                    vector(3, 0.001, 0.02), number(0.01, 1.0), vector(3, -0.2, 0.2),
                    matrix(np.ones((2, 6))), vector(2, -1.0, 1.0), Arg(st.booleans(), JUNK)))  # fmt: skip
def test_limits_are_finite_or_refused(args: tuple[Any, ...]) -> None:
    origin, rotation, lower, upper, gain, p, G, h, eq = args
    box = probe("WorkspaceBound", rp.WorkspaceBound, origin, rotation, lower, upper, gain,
                ok=fields_finite, names=("workspace",))  # fmt: skip
    if box is not None:
        probe("WorkspaceBound.coordinates", box.coordinates, p, ok=finite, names=("p",))
        probe("WorkspaceBound.depth", box.depth, p, ok=finite, names=("p",))
        probe("WorkspaceBound.outside", box.outside, p, ok=lambda d: finite(d) and np.all(d >= 0),
              names=("p",))  # fmt: skip
    # the cube's half width drawn as the gain is (its valid range within the half width's)
    probe("WorkspaceBound.cube", rp.WorkspaceBound.cube, origin, gain, ok=fields_finite,
          names=("workspace",))  # fmt: skip
    probe("Constraint", rp.Constraint, G, h, eq, names=("G", "h", "equality"),
          ok=lambda c: finite(c.G) and finite(c.h) and c.G.shape[0] == c.h.shape[0])  # fmt: skip
    # each limit with its own parameters, `gain` (possibly bad) where one is a gain or speed
    made = {"ActuatorLimit": (0.5e-3,), "RcmLimit": (0.5e-6,), "RetinaBarrier": (EYE, 2e-4, gain),
            "SingularMargin": (None, gain), "TipSpeed": (gain,)}  # fmt: skip
    for name in LIMITS:
        probe(name, getattr(rp, name), *made[name], names=("gain", "speed"),
              ok=lambda lim: callable(getattr(lim, "constraint", None))
              or callable(getattr(lim, "bounds", None)))  # fmt: skip


def realises(robot: Any, tip: Any, trocar: Any, checked: bool) -> Any:
    """A check of solve_pose's result: finite, lambda in [0, 1]; on iRAM!S with a target from
    rcm_target, the tip at `tip` and the RCM at `trocar`."""

    def ok(pose: Any) -> bool:
        if not (finite(pose.q) and 0.0 <= pose.lam <= 1.0):
            return False
        if robot is not ROBOT or not checked:
            return True
        there = np.allclose(ROBOT.tip(pose.q), np.asarray(tip, dtype=float), atol=1e-9)
        rcm = ROBOT.needle_point(pose.q, pose.lam)
        return there and np.allclose(rcm, np.asarray(trocar, dtype=float), atol=1e-9)

    return ok


@examples(250)
@given(args=one_bad(
    Arg(st.sampled_from([tip_of_target(t) for t in INSERT]), vector(3, -1e3, 1e3).any()),
    Arg(st.sampled_from([INSERT[0, 3:], [*INSERT[0, 3:]]]), vector(3, -0.2, 0.2).bad),
    number(-0.2, 0.2), number(-3.1, 3.1), number(-3.1, 3.1), choice([ROBOT, UR5], [None, "iramis"]),
    optional(Arg(st.just(np.zeros(6)), vector(6, -0.1, 0.1).bad)),
))  # fmt: skip
def test_targets_are_finite_or_refused(args: tuple[Any, ...]) -> None:
    tip, trocar, x, phi, psi, robot, seed = args
    x_ext = probe(
        "rcm_target", rp.rcm_target, tip, trocar, ok=shaped((6,)), names=("tip", "trocar")
    )
    probe("pivot_target", pivot_target, x, phi, psi, trocar, ok=shaped((6,)),
          names=("x_tip", "phi", "psi", "trocar"))  # fmt: skip
    target = x_ext if x_ext is not None else tip
    probe("solve_pose", rp.solve_pose, robot, target, seed, names=("robot", "x_ext", "seed"),
          ok=realises(robot, tip, trocar, x_ext is not None))  # fmt: skip


@examples(300)
@given(args=one_bad(vector(6, -0.01, 0.01), vector(6, -0.01, 0.01),
                    Arg(st.integers(1, 10), st.one_of(st.integers(-3, 0), BAD_SCALARS)),
                    number(1e-4, 1e-2), optional(number(1e-3, 0.1))))  # fmt: skip
def test_interpolation_and_splits_are_bounded_or_refused(args: tuple[Any, ...]) -> None:
    start, goal, n, step, angle = args
    rows = lambda r: finite(r) and 1 <= len(r) <= MAX_TARGETS  # noqa: E731
    probe("interpolate", interpolate, start, goal, n, ok=rows, names=("start", "goal", "n"))
    probe("split_steps", rp.split_steps, start, goal, step, angle, ok=rows,
          names=("start", "goal", "step"))  # fmt: skip


def test_a_split_that_would_allocate_gigabytes_is_refused_before_allocating() -> None:
    assert probe("split_steps", rp.split_steps, np.zeros(6), np.full(6, 0.1), 1e-5, 1e-9) is None
    assert probe("Steps.count", rp.Steps(1e-5, 1e-9).count, 0.01, 0.5) is None


LOOP = ("max_iterations", "drift_correction", "singular_threshold", "rcm_bound", "max_target_step",
        "rcm_tolerance")  # fmt: skip


def bounded_loop(cfg: Any) -> bool:
    return (fields_finite(cfg) and 1 <= cfg.max_iterations <= 100_000
            and isinstance(cfg.drift_correction, bool)
            and (cfg.rcm_bound is None or 0 < cfg.rcm_bound <= 0.01))  # fmt: skip


@examples(300)
@given(args=one_bad(
    Arg(st.integers(1, 10**5), st.one_of(st.integers(-5, 0), st.integers(10**5 + 1), JUNK)),
    Arg(st.booleans(), JUNK), optional(number(0.0, 0.99)), optional(number(1e-6, 0.01)),
    optional(number(1e-6, 0.1)), optional(number(1e-9, 1e-3)),
))  # fmt: skip
def test_loop_settings_are_bounded_or_refused(args: tuple[Any, ...]) -> None:
    probe("LoopSettings", rp.LoopSettings, *args, ok=bounded_loop, names=LOOP)


@examples(150)
@given(args=one_bad(number(0.0, 1.0), vector(5, -0.05, 0.05), number(0.01, 1.9),
                    number(0.1, 10.0)))  # fmt: skip
def test_configurations_objectives_and_depth_limits_are_finite_or_refused(
    args: tuple[Any, ...],
) -> None:
    lam, dq, gain, weight = args
    cfg = probe("Configuration", rp.Configuration, ROBOT, ROBOT.home, lam, names=("lam",),
                ok=lambda c: finite(c.kinematics.tip))  # fmt: skip
    obj = probe("Objective", rp.Objective, rp.Posture(), np.zeros(5), gain, weight,
                names=("gain", "weight"))  # fmt: skip
    if cfg is not None:
        probe("Configuration.integrate", cfg.integrate, dq, 0.0, names=("dq",),
              ok=lambda c: finite(c.q))  # fmt: skip
        if obj is not None:
            probe("Objective.cost", obj.cost, cfg, ok=lambda hf: finite(hf[0]) and finite(hf[1]))
    probe("TissueDepthLimit", rp.TissueDepthLimit, EYE.center, EYE.retina_radius, gain,
          names=("gain",), ok=lambda lim: math.isfinite(lim.gap_m(EYE.center)))  # fmt: skip
