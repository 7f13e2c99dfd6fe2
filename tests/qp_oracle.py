"""The compiled QP step of iRAM!S called alone from Python, for the tests that hold it to the
reference `QpSolver`: the problem its assembly leaves in its buffers (`problem`, as
`qp_problem.build_step` returns it) and its solve with its error (`solve`). What a user calls
one period at a time is `rcmplan.compiled.qp_period.period_step` (the solve, the RCM box held,
the joints' step); the loop calls the kernels itself."""

from __future__ import annotations

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.arm_qp import assembled_step
from rcmplan.compiled.daqp_c import exit_name
from rcmplan.compiled.qp_params import pack_extras, qp_params
from rcmplan.compiled.records import robot_params
from rcmplan.control.qp import QpSolver
from rcmplan.control.qp_problem import StepQP
from rcmplan.exceptions import QPError
from rcmplan.robot.iramis_kernels import trig


class QpStepOracle:
    """One QP step of a QpSolver on iRAM!S assembled and solved in compiled code. With a servo
    (`QpSolver.servo`) `solve` takes the joints the step is planned from
    (`QpSolver.planned_joints`) and synchronises the cost as the reference does
    (`qp_kernels.solve_step`). The eye must be the kernels' sphere (`qp_params`)."""

    def __init__(self, solver: QpSolver) -> None:
        params = qp_params(solver.robot, solver)
        assert params is not None, "the compiled QP step needs an eye whose retina is a sphere"
        self.solver = solver
        self.P = robot_params(solver.robot)
        self.Q, self.contacts = params
        self.K = np.ascontiguousarray(solver.K, dtype=np.float64)
        self._k = fast_cache.qp_kernels()
        self.qp = self._k.buffers()
        self.s, self.e, self.e_plan = np.empty(6), np.empty(6), np.empty(6)

    def problem(self, q: FloatArray, lam: float, target: FloatArray) -> StepQP:
        """The step's QP as `qp_problem.build_step` returns it (contact left False)."""
        q, target = np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(target, dtype=float)
        if self.solver.extra_limits:
            pack_extras(self.solver, self.Q)
        rows = self._k.build_step(self.P, self.Q, self.contacts, self.K, q, trig(q), float(lam),
                                  target, self.s, self.e, self.qp)  # fmt: skip
        return assembled_step(self.qp, rows, self.s)

    def solve(self, q: FloatArray, lam: float, target: FloatArray) -> tuple[FloatArray, FloatArray]:
        """(x, error J x* / K) of the step's QP; QPError naming DAQP's exit flag if not optimal."""
        q, target = np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(target, dtype=float)
        if self.solver.extra_limits:  # a moving limit's parameters as they are now
            pack_extras(self.solver, self.Q)
        # with a servo q are the joints of its command (`QpSolver.planned_joints`)
        e_plan = self.e_plan if self.solver.servo is not None else self.e_plan[:0]
        flag = self._k.solve_step(self.P, self.Q, self.contacts, self.K, q, trig(q), float(lam),
                                  target, self.s, self.e, self.qp, None, e_plan)  # fmt: skip
        if flag != 1:
            raise QPError(f"QP solve failed: daqp exit flag {flag} ({exit_name(flag)})",
                          problem=self.problem(q, lam, target).problem, result=flag)  # fmt: skip
        return self.qp[self._k.X].copy(), self.e.copy()
