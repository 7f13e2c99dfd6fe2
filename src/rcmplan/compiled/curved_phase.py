"""One phase of Algorithm 1 with a curved needle, compiled, in the one loop of every robot
(`algorithm.run_targets`): on a plant that reaches its commands exactly (the kinematic plant)
or on the dynamic MuJoCo plant, whose periods the loop runs, iRAM!S (`phase.run_phase_compiled`,
`mujoco_loop.run_phase_on_mujoco`) and an arm (`arm_phase.run_arm_phase_compiled`), each with
the curved needle's method codes.

Applies to `CurvedPinvSolver`, `CurvedDlsSolver` and `CurvedPoseSolver` (exact types; the pose
solver with at most six active joints) driving a robot `curved.curved_arrays` accepts, and on
the kinematic plant to the curved QP's free-space step `LimitedPoseSolver` (method
CURVED_POSE_LIMITED) and, on an arm, to the QP itself (CURVED_QP, `arm_qp.curved_qp_applies`;
iRAM!S's QP phases: `qp_phase`). The side
effects are the reference loop's: records (with the roll error) go to the controller's log, the
plant and controller.lam end where `Controller.converge` leaves them, and a stop raises the
reference exception with the partial log kept. Other plants take the Python loop.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from rcmplan._validate import FloatArray
from rcmplan.compiled import arm_phase
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.arm_qp import curved_qp_applies
from rcmplan.compiled.curved import curved_arrays
from rcmplan.compiled.phase import run_phase_compiled
from rcmplan.compiled.records import (
    is_curved,
    method_code,
)
from rcmplan.control.curved import LimitedPoseSolver
from rcmplan.control.qp import QpSolver
from rcmplan.control.solvers import Solver

if TYPE_CHECKING:
    from rcmplan.control.runner import ControlState as Controller

ITERATIONS_PER_TARGET = 4  # on the kinematic plant: 12,725 records / 9,768 targets (`curved`)


def applies(controller: Controller, solver: Solver) -> bool:
    """True for a curved needle's solver, its QP's free-space step, and its QP on an arm
    (iRAM!S's: `qp_phase`); whether the compiled path runs is `run_if_fast`'s."""
    if is_curved(method_code(solver)) or type(solver) is LimitedPoseSolver:
        return True
    arrays = curved_arrays(controller.robot)
    return type(solver) is QpSolver and arrays is not None and arrays.P is None


def run_if_fast(
    controller: Controller, solver: Solver, targets: FloatArray, pid: int, sid: int
) -> bool:
    """Run the phase compiled for a `CurvedTipRobot` itself: on a plant that reaches its
    commands exactly or around the dynamic MuJoCo plant's compiled period (iRAM!S's QP's
    limited free step among them; an arm's QP too); False (nothing done) otherwise."""
    arrays = curved_arrays(controller.robot)
    if arrays is None:
        return False
    if type(solver) is QpSolver and arrays.P is None and not curved_qp_applies(solver):
        return False
    if arrays.P is None:  # an arm
        if not arm_phase.whole_loop(controller, solver):
            return False
        arm_phase.run_arm_phase_compiled(controller, solver, targets, pid, sid, arrays)
        return True
    if not getattr(controller.plant, "exact_commands", False):
        if not getattr(controller.plant, "compiled_physics", False):
            return False
        if type(solver) is QpSolver:  # iRAM!S's QP runs its own loops (`runner`)
            return False
        closed = fast_cache.closed_loop()
        return bool(closed.run_phase_on_mujoco(controller, solver, targets, pid, sid, P=arrays.P))
    run_phase_compiled(controller, solver, targets, pid, sid, arrays.P,
                       per_target=ITERATIONS_PER_TARGET + 1)  # fmt: skip
    return True
