"""The QP controller on a serial arm (UR5, Panda): its compiled step against the Python step,
and the arm's singular terms against the numpy formulation they replaced.

Run alone: python benchmarks/bench_arm_qp.py. Needs the `qp` and `robots` extras. Times are
medians per call from Python (`_common.per_call`), alternating between two states so that no
cache of a state's solve hits.
- QP step: `QpSolver.error` then `QpSolver.step` at a state near the injection's p4 (the
  default eye, the default limits), against `arm_qp.ArmQpStep`'s (the controller's stand-in on
  the compiled path: the QP assembled with the same row kernels and solved by DAQP's C
  function in one compiled call).
- Where the step's time goes: the same solve (`arm_qp_kernels.solve_packed`, the one compiled
  call of `ArmQpStep`) at the same two states, timed in a compiled loop (what the step costs
  with no call from Python), against one call of it from Python (the call with its five
  arguments added); `error` + `step` adds the argument checks, the state's key and the copies.
- Singular terms: `SerialArm.singular_terms` (the measure kappa = s_min / s_max of
  [J_tip / l; N J_omega] and its exact gradient, `robot/chain_singular.py`) against the numpy
  SVD formulation kept as the tests' oracle (`tests/chain_oracle.py`).
"""

from __future__ import annotations

import sys
from itertools import cycle
from pathlib import Path
from typing import Any

from numba import njit

from _common import per_call, quick, row
from rcmplan.compiled.arm_qp import ArmQpStep
from rcmplan.compiled.arm_qp_kernels import solve_packed
from rcmplan.control.qp import QpSolver
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.robot.shipped import shipped_arm
from rcmplan.scene.eye import default_eye, default_points

ARMS = {"ur5": "UR5", "panda": "Panda"}


def states(arm: Any) -> tuple[list[tuple[Any, float]], Any]:
    """Two states near the pose at p4 and the RCM target there."""
    eye = default_eye(arm)
    target = rcm_target(default_points(eye).p4, eye.port)
    pose = solve_pose(arm, target)
    return [(pose.q + d, pose.lam) for d in (1e-5, 2e-5)], target


def qp_step_us(name: str, compiled: bool, n: int) -> float:
    """Median time of one error + step of the arm's QP from Python in [us]."""
    arm = shipped_arm(name)
    solver = QpSolver(arm, default_eye(arm))
    stepper: Any = ArmQpStep(solver) if compiled else solver
    pair, target = states(arm)
    it = cycle(pair)

    def step() -> None:
        q, lam = next(it)
        e = stepper.error(arm, q, lam, target)
        stepper.step(arm, q, lam, target, e)

    return 1e6 * per_call(step, n)


@njit(cache=True)
def _solves(F: Any, Z: Any, q0: Any, q1: Any, lam: float, target: Any, n: int) -> int:
    """n solves alternating between joints q0 and q1; returns the optimal count."""
    ok = 0
    for i in range(n):
        ok += solve_packed(F, Z, q0 if i % 2 == 0 else q1, lam, target) == 1
    return ok


def solve_us(name: str, compiled_loop: bool, n: int) -> float:
    """Median time of the compiled step's solve in [us], in a compiled loop or called from
    Python (`ArmQpStep`'s packed arrays; both states share lambda)."""
    arm = shipped_arm(name)
    fast = ArmQpStep(QpSolver(arm, default_eye(arm)))
    ((q0, lam), (q1, _)), target = states(arm)
    if compiled_loop:
        batch = 20
        return 1e6 * per_call(lambda: _solves(fast.F, fast.Z, q0, q1, lam, target, batch),
                              n // batch) / batch  # fmt: skip
    it = cycle([q0, q1])
    return 1e6 * per_call(lambda: solve_packed(fast.F, fast.Z, next(it), lam, target), n)


def singular_us(name: str, oracle: bool, n: int) -> float:
    """Median time of the arm's singular terms (value and gradient) in [us]."""
    arm = shipped_arm(name)
    if oracle:
        sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
        from chain_oracle import singular_terms

        def terms(q: Any) -> Any:
            return singular_terms(arm, q)
    else:
        terms = arm.singular_terms
    it = cycle([arm.home + 1e-3, arm.home + 2e-3])
    return 1e6 * per_call(lambda: terms(next(it)), n)


def rows() -> list[dict[str, Any]]:
    """Per arm: the QP step, compiled against Python; the singular terms against numpy."""
    n, slow = (200, 20) if quick() else (2000, 200)
    out = []
    for name, label in ARMS.items():
        out.append(row(f"{label} QP error + step from Python, compiled (arm_qp.ArmQpStep)",
                       qp_step_us(name, True, n), "us", "rcmplan QpSolver (Python)",
                       qp_step_us(name, False, slow), "<= 10 us"))  # fmt: skip
        out.append(row(f"{label} QP step's solve in a compiled loop (arm_qp_kernels.solve_packed)",
                       solve_us(name, True, n), "us", "the same solve called from Python",
                       solve_us(name, False, n)))  # fmt: skip
        out.append(row(f"{label} singular terms (kappa and gradient) from Python",
                       singular_us(name, False, n), "us", "numpy SVD (tests/chain_oracle.py)",
                       singular_us(name, True, slow)))  # fmt: skip
    return out


if __name__ == "__main__":
    from run import print_table

    print_table(rows())
