"""The compiled runner: compiled iRAM!S kinematics, batched evaluation and a compiled control
loop, behind the controller's runner seam (`rcmplan.control.runner`).

`CompiledRunner` decides by itself whether it applies: the robot must be one whose kinematics
the iRAM!S kernels reproduce (`kernel_params` checks the kernels against the model at probe
configurations, so a subclass with other geometry runs on the reference path), the solver one
of the methods the kernels implement (exact types: a subclass may change `step`), and the plant
one that says what it can do (`exact_commands`: a command is reached exactly in one period;
`compiled_physics`: its period can run in compiled code).

Where it applies it always runs, from the first target on (numba compiles each kernel at its
first call with a set of argument types and caches it: `rcmplan._jit`). Results equal the
reference Python loop's to rounding (tests/test_fast.py checks 1e-12).
"""

from __future__ import annotations

import weakref
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray, vector
from rcmplan.compiled import arm_phase, curved_phase, qp_mujoco_phase, qp_phase
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.arm import check_arm_targets
from rcmplan.compiled.curved import check_curved_targets
from rcmplan.compiled.phase import run_phase_compiled, run_phase_on_plant
from rcmplan.compiled.records import iramis_method, method_code, robot_params
from rcmplan.control.solvers import Solver
from rcmplan.control.targets import solve_pose
from rcmplan.control.tasks import VARIANTS, JacobianVariant
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot import iramis_kernels
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel, SerialArm

if TYPE_CHECKING:
    from rcmplan.control.runner import ControlState as Controller

__all__ = [
    "FastIramis",
    "fast_check_targets",
    "fast_converge_phase",
    "method_code",
    "robot_params",
]


def fast_converge_phase(
    controller: Controller, solver: Solver, targets: FloatArray, pid: int, sid: int
) -> bool:
    """Run Algorithm 1 on every target of a phase in compiled code, if it applies.

    Applies when the solver is a PinvSolver, DlsSolver or TipSolver, or a QpSolver on a serial
    arm (the arm loop, `arm_phase`); a QpSolver on iRAM!S (with a straight or a curved needle)
    and the kinematic plant runs its own compiled loop (`qp_phase`), on the dynamic MuJoCo
    plant with the plant as its servo another (`qp_mujoco_phase`), a curved needle's solver
    its own phases (`curved_phase`, on the kinematic plant). On a KinematicPlant, and on a dynamic
    MujocoPlant (physics through MuJoCo's C functions, `fast_mujoco`), the whole loop is
    compiled; on any other plant the plant steps in Python and each iteration's control work
    is one compiled call. Records go to controller.log, the plant and controller.lam end where the
    reference loop leaves them, and an early stop raises the reference loop's exception.
    Returns False (nothing done) otherwise.
    """
    if curved_phase.applies(controller, solver):  # a curved needle, on the kinematic plant
        return curved_phase.run_if_fast(controller, solver, targets, pid, sid)
    if arm_phase.applies(controller, solver):  # any serial arm, on any plant
        return arm_phase.run_if_fast(controller, solver, targets, pid, sid)
    dynamic = qp_mujoco_phase.applies(controller, solver)  # the QP on the dynamic MuJoCo plant
    if dynamic or qp_phase.applies(controller, solver):  # or on the kinematic plant
        curved = getattr(solver, "curved", False)
        robot = controller.robot
        P = qp_phase.curved_params(robot) if curved else kernel_params(robot)
        if P is None:
            return False
        if dynamic:
            return qp_mujoco_phase.run_if_ready(controller, solver, targets, pid, sid, P)  # type: ignore[arg-type]
        return qp_phase.run_if_ready(controller, solver, targets, pid, sid, P)  # type: ignore[arg-type]
    exact = getattr(controller.plant, "exact_commands", False)
    physics = getattr(controller.plant, "compiled_physics", False)
    # The QP's free-space step (`LimitedTipSolver`) has no `method_code`: it runs compiled on
    # iRAM!S with exact commands or in the closed MuJoCo loop (`records.iramis_method`).
    if method_code(solver) is None and not (
        (exact or physics) and iramis_method(solver, controller.robot) is not None
    ):
        return False
    if kernel_params(controller.robot) is None:
        return False
    if exact:
        run_phase_compiled(controller, solver, targets, pid, sid)
        return True
    if physics:
        done = fast_cache.closed_loop().run_phase_on_mujoco(controller, solver, targets, pid, sid)
        if done:
            return True
    if method_code(solver) is None:  # the per-iteration path runs `method_code`'s solvers
        return False
    run_phase_on_plant(controller, solver, targets, pid, sid)
    return True


_PROBES = np.array([[4e-3, 0.3, -6e-3, -0.2, 5e-3, 0.4], [-9e-3, -0.5, 2e-3, 0.6, -3e-3, -1.1],
                    [1e-3, 0.05, 1e-2, 0.12, 2e-2, 0.0]])  # fmt: skip
_kernel_ok: weakref.WeakKeyDictionary[object, FloatArray | None] = weakref.WeakKeyDictionary()


def kernel_params(robot: RobotModel) -> FloatArray | None:
    """The kernels' parameter vector for `robot` if the iRAM!S kernels reproduce its needle
    points, actuator map and angle rows at three probe configurations (1e-12), else None."""
    if robot in _kernel_ok:
        return _kernel_ok[robot]
    P: FloatArray | None = None
    if isinstance(robot, Iramis):
        P = robot_params(robot)
        k = iramis_kernels
        out = np.empty(3)
        for q in _PROBES:
            s = np.empty(6)
            k.actuators_from_joints(P, q, s)
            ok = np.allclose(s, robot.actuators_from_joints(q), rtol=0.0, atol=1e-12)
            for lam in (0.0, 0.7, 1.0):
                k.needle_point(P, q, lam, out)
                ok &= np.allclose(out, robot.needle_point(q, lam), rtol=0.0, atol=1e-12)
            ok &= np.array_equal(robot.needle_angles_jacobian(q), Iramis.needle_angles_jacobian(
                robot, q))  # fmt: skip
            if not ok:
                P = None
                break
    _kernel_ok[robot] = P
    return P


def fast_check_targets(robot: RobotModel, targets: FloatArray) -> bool:
    """`solve_pose` on every X_ext target, screened in compiled code; False if not done (not an
    (N, 6) array, or a robot the kernels do not reproduce).

    The kernel flags every target that might fail (same formulas, margin 1e-12); flagged
    targets go through `solve_pose` in order, which raises the reference exception. A serial
    arm is screened by `arm.check_arm_targets` (Newton's method compiled).
    """
    targets = np.ascontiguousarray(targets, dtype=np.float64)
    if targets.ndim != 2 or targets.shape[1] != 6:
        return False
    if isinstance(robot, SerialArm):
        return check_arm_targets(robot, targets)
    flags = screen_flags(robot, targets)
    if flags is None:
        return False
    for i in np.flatnonzero(flags):
        solve_pose(robot, targets[i])
    return True


def screen_flags(robot: RobotModel, targets: FloatArray) -> NDArray[np.bool_] | None:
    """Per X_ext target (N, 6), each on its own: True where `solve_pose` might fail (the
    closed forms in compiled code, margin 1e-12), False where it certainly succeeds; None for
    a robot the iRAM!S kernels do not reproduce (`kernel_params`)."""
    if kernel_params(robot) is None:
        return None
    targets = np.ascontiguousarray(targets, dtype=np.float64)
    flags = np.zeros(targets.shape[0], dtype=np.bool_)
    k = fast_cache.loop_kernels()
    k.screen_targets(robot_params(robot), robot.singular_threshold, targets, flags)
    return flags


def _variant(variant: JacobianVariant) -> bool:
    if variant not in VARIANTS:
        raise InvalidInputError("variant", variant, f"one of {VARIANTS}")
    return variant == "thesis"


class FastIramis:
    """Compiled closed-form task values, J_a and the control step of an Iramis robot.

    Args:
        robot: The robot (default: thesis iRAM!S). Raises MissingExtraError without numba.
    """

    def __init__(self, robot: Iramis | None = None) -> None:
        self.robot = robot or Iramis()
        self.P = robot_params(self.robot)
        self._k: ModuleType = fast_cache.kernels()

    def task(self, q: FloatArray, lam: float) -> FloatArray:
        """X_ext = (x_tip [m], phi, psi [rad], p_rcm [m]) at (q, lambda), a (6,) array."""
        x = np.empty(6)
        self._k.extended_task(self.P, np.ascontiguousarray(vector("q", q, 6)), float(lam), x)
        return x

    def augmented_jacobian(
        self, q: FloatArray, lam: float, variant: JacobianVariant = "exact"
    ) -> FloatArray:
        """J_a (6, 6) at (q, lambda), "exact" or "thesis" angle rows."""
        J = np.empty((6, 6))
        q = np.ascontiguousarray(vector("q", q, 6))
        self._k.augmented_jacobian(self.P, q, float(lam), _variant(variant), J)
        return J

    def step(
        self,
        q: FloatArray,
        lam: float,
        target: FloatArray,
        K: FloatArray,
        variant: JacobianVariant = "exact",
        out: FloatArray | None = None,
    ) -> FloatArray:
        """One control step d = J_a^-1 K (target - X_ext): (dq0..dq4 [m, rad], dlambda), (6,).

        No argument checks (the hot path): q (6,), target (6,) and K (6,) must be float64
        arrays; `out` (6,) is filled and returned when given.
        """
        d = np.empty(6) if out is None else out
        self._k.pinv_step(self.P, q, lam, target, K, variant == "thesis", d)
        return d

    def batch_task_jacobians(
        self, Q: FloatArray, lam: FloatArray, variant: JacobianVariant = "exact"
    ) -> tuple[FloatArray, FloatArray]:
        """X_ext (N, 6) and J_a (N, 6, 6) for joints Q (N, 6) and lambdas (N,), one core."""
        Q = np.ascontiguousarray(Q, dtype=np.float64)
        lam = np.ascontiguousarray(lam, dtype=np.float64)
        if Q.ndim != 2 or Q.shape[1] != 6 or lam.shape != (Q.shape[0],):
            raise InvalidInputError("(Q, lam)", (Q.shape, lam.shape), "shapes (N, 6) and (N,)")
        X = np.empty((Q.shape[0], 6))
        J = np.empty((Q.shape[0], 6, 6))
        self._k.batch_task_jacobians(self.P, Q, lam, _variant(variant), X, J)
        return X, J


class CompiledRunner:
    """The compiled path behind the controller's seam (see the module docstring)."""

    def check_targets(self, robot: RobotModel, targets: FloatArray) -> bool:
        """Screen targets in compiled code, where it applies."""
        return fast_check_targets(robot, targets)

    def check_curved_targets(
        self, robot: RobotModel, targets: FloatArray, seed: FloatArray | None
    ) -> FloatArray | None:
        """Screen a curved needle's targets in compiled code, where it applies."""
        return check_curved_targets(robot, targets, seed)

    def run_phase(
        self, controller: Controller, solver: Solver, targets: FloatArray, pid: int, sid: int
    ) -> bool:
        """Run a phase in compiled code, where it applies."""
        return fast_converge_phase(controller, solver, targets, pid, sid)
