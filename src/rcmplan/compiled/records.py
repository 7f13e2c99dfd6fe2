"""What the compiled loops and the controller exchange, defined once: the kernels' method and
status codes, the record layout, the parameter vector of the iRAM!S kernels, and the conversion
of a compiled early stop into the exception the reference loop raises.

No numba here: the compiled loops read these module constants as compile-time constants.
Solvers are recognised by exact type, so a subclass that changes `step` runs on the reference
path.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.control.curved import (
    CurvedDlsSolver,
    CurvedPinvSolver,
    CurvedPoseSolver,
    LimitedPoseSolver,
)
from rcmplan.control.curved_step import CURVED as CURVED
from rcmplan.control.curved_step import CURVED_DLS as CURVED_DLS
from rcmplan.control.curved_step import CURVED_PINV as CURVED_PINV
from rcmplan.control.curved_step import CURVED_POSE as CURVED_POSE
from rcmplan.control.curved_step import CURVED_POSE_LIMITED as CURVED_POSE_LIMITED
from rcmplan.control.curved_step import CURVED_QP as CURVED_QP
from rcmplan.control.limited_tip import LimitedTipSolver
from rcmplan.control.log import LogBuilder
from rcmplan.control.solvers import DlsSolver, PinvSolver, Solver, TipSolver
from rcmplan.control.targets import tip_of_target
from rcmplan.exceptions import ConvergenceError, InvalidInputError, RcmplanError
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel

if TYPE_CHECKING:
    from rcmplan.control.runner import ControlState as Controller

PINV, PINV_THESIS, DLS, TIP = 0, 1, 2, 3  # method codes of the kernels
# The QP's free-space step (`LimitedTipSolver`): the TIP step scaled to hold the actuators'
# speed and travel (and a tip speed). The iRAM!S loop (`iramis_method`) and the arm loop run it.
TIP_LIMITED = 4
# The QP controller: one solve gives an iteration's error and step, in the arm loop
# (`arm_phase.arm_code`) and the iRAM!S loop (`qp_phase`, `qp_mujoco_phase`)
QP = 5
# A curved needle's methods (`rcmplan.control.curved`): codes from CURVED on (X_c, 7 rows), each
# its solver's `code` (`rcmplan.control.curved_step`)
DONE, PAUSED, NO_CONVERGENCE, SINGULAR, BAD_JOINTS, SLIDER_LIMIT, NO_TIP, STEPPED = range(8)
QP_FAILED = 8  # DAQP did not return an optimal solution (its exit flag in info[2])
PLANT_STOPPED = 100  # the dynamic MuJoCo plant's period failed a check (code in info[2])
BLOCK = 4096  # records buffered before they go to the log
REC_COLUMNS = {"time": (0, 1), "sliders": (1, 7), "joints": (7, 13), "lam": (13, 14),
               "tip": (14, 17), "rcm": (17, 20), "trocar": (20, 23), "base": (23, 26),
               "target_tip": (26, 29), "error": (29, 35)}  # fmt: skip
REC_WIDTH = 35
VECTORS = tuple(k for k, (a, b) in REC_COLUMNS.items() if b - a > 1)
# fail of the iRAM!S loop: (q, q_new, s_new, error (6,), or (7,) curved); the QP's actuators
# s_qp and a servo's scratch after the error (`loop.iterate`)
FAIL_WIDTH = 51


def record_columns(n: int, roll: bool = False) -> dict[str, tuple[int, int]]:
    """The record layout for a robot with n joints (actuators): field -> (first, end) column.
    The same fields in the same order as REC_COLUMNS, which is this layout for n = 6. With
    `roll` (a curved needle) a last column holds the roll error [rad]; straight rows end
    before it (the log gets NaN)."""
    widths = {"time": 1, "sliders": n, "joints": n, "lam": 1, "tip": 3, "rcm": 3, "trocar": 3,
              "base": 3, "target_tip": 3, "error": 6}  # fmt: skip
    if roll:
        widths["roll_error"] = 1
    ends = np.cumsum(list(widths.values()))
    return {k: (int(e - w), int(e)) for (k, w), e in zip(widths.items(), ends, strict=True)}


def record_width(n: int, roll: bool = False) -> int:
    """Columns of a record row for n joints (REC_WIDTH for n = 6), one more with `roll`."""
    return 2 * n + 23 + int(roll)


def is_curved(code: int | None) -> bool:
    """True for a curved needle's method code."""
    return code is not None and code >= CURVED


LOWER_AT = 7  # P's travel starts here (`iramis_kernels.PARAMS`)


def robot_params(robot: RobotModel) -> FloatArray:
    """The parameter vector P of the kernels: l1..l6 [m], PCJM spacing d [m], travel (6 + 6)."""
    if not isinstance(robot, Iramis):
        raise InvalidInputError("robot", robot.name, "an iRAM!S model (the kernels' closed form)")
    return np.array([*robot.P[:LOWER_AT], *robot.lower, *robot.upper], dtype=np.float64)


def method_code(solver: Solver) -> int | None:
    """The kernel's method code for a solver the compiled loop reproduces, else None."""
    if type(solver) is PinvSolver:
        return PINV if solver.variant == "exact" else PINV_THESIS
    if type(solver) is DlsSolver:
        return DLS
    if type(solver) is TipSolver:
        return TIP
    if type(solver) in (CurvedPinvSolver, CurvedDlsSolver, CurvedPoseSolver):
        return int(solver.code)  # type: ignore[attr-defined]
    return None


def iramis_method(solver: Solver, robot: RobotModel) -> tuple[int, FloatArray] | None:
    """(method code, K) of a solver the iRAM!S loop (`loop.iterate`) reproduces, else None.

    `method_code`'s solvers keep their K. The QP's limited free-space step (`LimitedTipSolver`)
    runs as TIP_LIMITED; its K (8,) carries what the step holds: each actuator's largest move
    per period (speed x dt, 6), the travel margin and the tip's largest move per axis and
    period (tip speed x dt; 0: no tip speed bound). The curved QP's free-space step
    (`LimitedPoseSolver`) runs as CURVED_POSE_LIMITED with K (15,): its gains (7,), then the
    same bounds."""
    if type(solver) is LimitedPoseSolver:
        K = np.concatenate([solver.K, np.asarray(robot.speed, dtype=np.float64) * solver.dt,
                            (solver.travel_margin, 0.0)])  # fmt: skip
        return CURVED_POSE_LIMITED, K
    if type(solver) is LimitedTipSolver:
        tip = 0.0 if solver.tip_speed is None else solver.tip_speed * solver.dt
        K = np.append(np.asarray(robot.speed, dtype=np.float64) * solver.dt,
                      (solver.travel_margin, tip))  # fmt: skip
        return TIP_LIMITED, K
    code = method_code(solver)
    return None if code is None else (code, solver_arrays(solver)[0])


def solver_arrays(solver: Solver) -> tuple[FloatArray, float, FloatArray]:
    """(K (6,) or (7,), damping [m], tolerance padded to at least (6,)) of a supported
    solver."""
    K = np.asarray(getattr(solver, "K", (1.0,) * 6), dtype=np.float64)
    tol = np.zeros(max(6, solver.tolerance().shape[0]))
    t = solver.tolerance()
    tol[: t.shape[0]] = t
    return K, float(getattr(solver, "damping", 0.0)), tol


def singular_threshold(controller: Controller) -> float:
    """The loop's singular threshold: its own setting, else the robot's."""
    own = controller.settings.singular_threshold
    return float(controller.robot.singular_threshold if own is None else own)


def loop_bounds(controller: Controller) -> FloatArray:
    """The compiled loops' `bounds` (2,): the singular threshold and the RCM tolerance of one
    step in [m] (0: none)."""
    bound = controller.settings.rcm_tolerance
    return np.array([singular_threshold(controller), 0.0 if bound is None else bound])


def append_rows(
    log: LogBuilder, rec: FloatArray, irec: NDArray[np.int64], count: int, n: int, pid: int,
    sid: int,
) -> None:  # fmt: skip
    """Append the first `count` records of an n-joint layout (`record_columns`; with the roll
    error when rec has its column) to a log."""
    layout = record_columns(n, roll=rec.shape[1] > record_width(n))
    cols: dict[str, object] = {k: rec[:count, a:b] for k, (a, b) in layout.items()}
    for k in ("time", "lam", "roll_error"):
        cols[k] = rec[:count, layout[k][0]] if k in layout else np.nan
    log.extend(count, step=irec[:count, 0], iteration=irec[:count, 1], solver=sid, phase=pid,
               **cols)  # fmt: skip


def where(controller: Controller, pid: int, k: int) -> str:
    """Where a stop happened, as the reference loop names it: phase pid's name, target k."""
    return f"phase {controller.log.phase_names[pid]!r} step {k}"


def raise_stop(
    controller: Controller, status: int, k: int, targets: FloatArray, fail: FloatArray,
    tol: FloatArray, where: str,
) -> None:  # fmt: skip
    """Raise the exception the reference loop raises for a compiled early stop."""
    robot, cfg = controller.robot, controller.settings
    q, qn, sn, e = fail[0:6].copy(), fail[6:12].copy(), fail[12:18].copy(), fail[18:]
    if status == NO_CONVERGENCE:
        raise ConvergenceError(cfg.max_iterations, np.abs(e[: tol.size]), tol, where=where)
    checks: dict[int, Any] = {
        SINGULAR: lambda: robot.check_singularity(q, cfg.singular_threshold),
        BAD_JOINTS: lambda: robot.actuators_from_joints(qn),
        SLIDER_LIMIT: lambda: robot.check_actuators(sn),
        NO_TIP: lambda: tip_of_target(targets[k]),
    }
    checks[status]()
    raise RcmplanError(f"compiled loop stopped with status {status} at target {k}")


def raise_arm_stop(
    controller: Controller, status: int, target: FloatArray, fail: FloatArray, n: int,
    tol: FloatArray, where: str,
) -> None:  # fmt: skip
    """Raise the exception the reference loop raises for a compiled arm loop's early stop.

    fail holds (q (n,), q_new (n,), error (6,), or (7,) for a curved needle) of the last
    iteration. The failing check is
    repeated with the reference function (the plant's command for BAD_JOINTS and SLIDER_LIMIT),
    which raises the same exception with the same message.
    """
    robot, cfg = controller.robot, controller.settings
    q, qn = fail[:n].copy(), fail[n : 2 * n].copy()
    if status == NO_CONVERGENCE:
        e = np.abs(fail[2 * n : 2 * n + tol.shape[0]])
        raise ConvergenceError(cfg.max_iterations, e, tol, where=where)
    checks: dict[int, Any] = {
        SINGULAR: lambda: robot.check_singularity(q, cfg.singular_threshold),
        BAD_JOINTS: lambda: controller.plant.command_actuators(robot.actuators_from_joints(qn)),
        SLIDER_LIMIT: lambda: controller.plant.command_actuators(robot.actuators_from_joints(qn)),
        NO_TIP: lambda: tip_of_target(target),
    }
    checks[status]()
    raise RcmplanError(f"compiled arm loop stopped with status {status} at {where}")
