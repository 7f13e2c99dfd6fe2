"""An episode's periods a block at a time in compiled code (`compiled.qp_periods`).

A block is the periods `Episode.plan` planned at once: from one iOCT estimate's arrival to the
next. One compiled call runs them all; its records then go to the log and the series
(`Episode.store`, which also runs the tissue model over the block's tips: the tissue does not
feed back into the control). The block loop applies where the per-period path's step is the
compiled iRAM!S step (`qp_period.period_step`: a plain QpSolver with DAQP, a straight needle,
no servo plan, a robot the iRAM!S kernels reproduce, DAQP's C function callable) on a plant
that reaches its commands exactly and does not round them (the kinematic plant); on the
dynamic MuJoCo plant the episode runs one period at a time.

Where the kernel stops before a period's move (a failed QP solve, joints no sliders realise, a
slider beyond travel), that period runs on the per-period path (`Episode.period`), which
raises the reference exception (or, for a solve that fails only in compiled code, takes the
reference step and goes on); an RCM deviation past the bound raises RcmBoundError after the
period's record, as the per-period path does.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.qp_params import EXTRA, EXTRA_SLOT, qp_params
from rcmplan.compiled.qp_phase import runs_compiled
from rcmplan.compiled.records import DONE, REC_COLUMNS, REC_WIDTH, VECTORS, robot_params
from rcmplan.compiled.runner import kernel_params
from rcmplan.control.limits.tissue_depth import FLOOR_AT, TissueDepthLimit
from rcmplan.exceptions import MissingExtraError, RcmBoundError

if TYPE_CHECKING:
    from types import ModuleType


class Episode(Protocol):
    """What the block loop reads and calls of an episode (`subretinal.episode.Episode`)."""

    cfg: Any
    robot: Any
    plant: Any
    eye: Any
    solver: Any
    log: Any
    t_s: np.ndarray
    targets: np.ndarray
    desired: np.ndarray
    floor_m: np.ndarray
    trocar_m: np.ndarray
    center_m: np.ndarray
    phase: np.ndarray
    phase_names: Any

    def period(self) -> None: ...
    def store(
        self, k: int, tips: np.ndarray, bases: np.ndarray, deviation_m: np.ndarray
    ) -> None: ...


def floor_index(extra_limits: tuple[object, ...]) -> int:
    """Where the depth limit's floor radius sits in the QP's parameters Q (`qp_params`: the
    extra limits' slots, each its kind then its packed numbers), or -1 without one."""
    for i, lim in enumerate(extra_limits):
        if isinstance(lim, TissueDepthLimit):
            return EXTRA + i * EXTRA_SLOT + 1 + FLOOR_AT
    return -1


class PeriodBlocks:
    """The compiled block loop of one episode (module docstring); `make` says if it applies."""

    def __init__(self, ep: Episode, kernels: ModuleType, params: tuple) -> None:
        self.kernels = kernels
        solver = ep.solver
        self.P = robot_params(ep.robot)
        self.Q, self.contacts = params
        self.K = np.ascontiguousarray(solver.K, dtype=np.float64)
        self.floor_at = floor_index(solver.extra_limits)
        self.qp = fast_cache.qp_kernels().buffers()
        self.info = np.zeros(3, dtype=np.int64)
        self.sid = ep.log.solver_id(solver.name)
        self.pid_of = np.array([ep.log.phase_id(p) for p in ep.phase_names])
        self.call(ep, 0, 0, ep.plant.read_actuators(), np.empty((0, REC_WIDTH)), np.empty(0))
        # (no period: numba loads the compiled code now, not in the first block)

    def call(self, ep: Episode, k: int, end: int, s: np.ndarray, rec: np.ndarray,
             deviation: np.ndarray) -> int:  # fmt: skip
        """The kernel on periods k..end-1 from sliders s; returns its status."""
        return int(self.kernels.run_periods(
            self.P, self.Q, self.contacts, self.K, self.floor_at, ep.cfg.rcm_bound_m,
            ep.trocar_m[k:end], ep.t_s[k:end], ep.targets[k:end], ep.desired[k:end],
            ep.floor_m[k:end], ep.center_m[k:end], s, rec, deviation, self.info, self.qp,
        ))  # fmt: skip

    @classmethod
    def make(cls, ep: Episode) -> PeriodBlocks | None:
        """The block loop of an episode, or None where it does not apply (module docstring)."""
        solver, plant = ep.solver, ep.plant
        if not getattr(plant, "exact_commands", False):
            return None
        if getattr(plant, "actuator_resolution", None) is not None or solver.servo is not None:
            return None
        if kernel_params(ep.robot) is None:
            return None
        try:
            kernels = fast_cache.qp_periods()
        except MissingExtraError:
            return None
        params = qp_params(ep.robot, solver)
        if kernels is None or params is None or not runs_compiled(solver, True):
            return None
        return cls(ep, kernels, params)

    def run(self, ep: Episode, k: int, end: int) -> None:
        """Run periods k..end-1 (planned) from the plant's sliders; records to the log and the
        series, the plant at the last command (module docstring for a stop)."""
        plant, n_block = ep.plant, end - k
        s = plant.read_actuators()
        rec, deviation = np.empty((n_block, REC_WIDTH)), np.empty(n_block)
        status = self.call(ep, k, end, s, rec, deviation)
        n = int(self.info[0])
        if n > 0:
            self.log_records(ep, k, rec[:n])
            (tip_a, tip_b), (base_a, base_b) = REC_COLUMNS["tip"], REC_COLUMNS["base"]
            ep.store(k, rec[:n, tip_a:tip_b], rec[:n, base_a:base_b], deviation[:n])
            time_s = plant.time
            plant.command_actuators(s)
            plant.advance()
            plant.time = time_s + n * plant.dt
        if status == DONE:
            return
        if status == self.kernels.RCM_BOUND:
            phase = ep.phase_names[ep.phase[k + n - 1]]
            raise RcmBoundError(phase, float(deviation[n - 1]), ep.cfg.rcm_bound_m)
        ep.period()  # the stopped period on the per-period path: the reference exception

    def log_records(self, ep: Episode, k: int, rec: np.ndarray) -> None:
        """Append the block's records (periods k.., rows of `records.REC_COLUMNS`) to the log."""
        n = rec.shape[0]
        vectors = {key: rec[:, a:b] for key, (a, b) in REC_COLUMNS.items() if key in VECTORS}
        ep.log.extend(n, time=rec[:, 0], lam=rec[:, 13], step=np.arange(k, k + n), iteration=0,
                      solver=self.sid, phase=self.pid_of[ep.phase[k : k + n]],
                      **vectors)  # fmt: skip
