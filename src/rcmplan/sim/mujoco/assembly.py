"""Close the PCJM loops of a MuJoCo model: residual, loop-closure gap and Newton assembly.

The residual of each `connect` equality is the world-frame gap between the pin on the slider
and the pin riding in the stage slot. Assembly holds the slider joints and moves the passive
joints (stage guide, stage hinge, slot pins) by Gauss-Newton steps on MuJoCo's own kinematics
and Jacobians, so the closed loop is solved by the model, not by the planner's formulas.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.exceptions import SimulationError
from rcmplan.robot.iramis import SLIDER_NAMES
from rcmplan.sim.mujoco.model import CONNECTS

PASSIVE_JOINTS = ("q0", "q1", "q2", "q3", *(f"slot_{n}" for n in CONNECTS))


@dataclass(frozen=True)
class LoopIndex:
    """Indices of the loop sites and joints in a compiled model.

    Attributes:
        slot_sites, pin_sites: Site ids of the two pins of each loop (L1, L2, L3, L4).
        slider_qpos: qpos addresses of (L1, L2, L3, L4, L5, q5).
        slider_dof: dof addresses of the sliders.
        passive_dof: dof (= qpos) addresses of the passive joints.
    """

    slot_sites: tuple[int, ...]
    pin_sites: tuple[int, ...]
    slider_qpos: tuple[int, ...]
    slider_dof: tuple[int, ...]
    passive_dof: tuple[int, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "slot_array", np.array(self.slot_sites, dtype=np.intp))
        object.__setattr__(self, "pin_array", np.array(self.pin_sites, dtype=np.intp))

    slot_array: NDArray[np.intp] = field(init=False, repr=False, compare=False)
    pin_array: NDArray[np.intp] = field(init=False, repr=False, compare=False)

    @classmethod
    def of(cls, mj: Any, model: Any) -> LoopIndex:
        """Look the names up in `model` (mj is the mujoco module)."""

        def site(name: str) -> int:
            return int(mj.mj_name2id(model, mj.mjtObj.mjOBJ_SITE, name))

        def joint(name: str) -> int:
            return int(mj.mj_name2id(model, mj.mjtObj.mjOBJ_JOINT, name))

        sliders = [joint(n) for n in SLIDER_NAMES]
        return cls(
            tuple(site(f"slot_{n}") for n in CONNECTS),
            tuple(site(f"pin_{n}") for n in CONNECTS),
            tuple(int(model.jnt_qposadr[j]) for j in sliders),
            tuple(int(model.jnt_dofadr[j]) for j in sliders),
            tuple(int(model.jnt_dofadr[joint(n)]) for n in PASSIVE_JOINTS),
        )


def loop_residual(data: Any, index: LoopIndex) -> FloatArray:
    """Gap vectors slot pin - slider pin, (4, 3) in [m], from the current site positions."""
    xpos = data.site_xpos
    return np.asarray(xpos[index.slot_array] - xpos[index.pin_array], dtype=float)


def loop_gap(data: Any, index: LoopIndex) -> float:
    """Largest loop-closure gap in [m] at the current site positions."""
    r = loop_residual(data, index)
    return math.sqrt(float((r * r).sum(axis=1).max()))


def _jacobian(mj: Any, model: Any, data: Any, index: LoopIndex) -> FloatArray:
    rows = []
    jp1, jp2 = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    for a, b in zip(index.slot_sites, index.pin_sites, strict=True):
        mj.mj_jacSite(model, data, jp1, None, a)
        mj.mj_jacSite(model, data, jp2, None, b)
        rows.append(jp1 - jp2)
    return np.vstack(rows)[:, list(index.passive_dof)]


def assemble(
    mj: Any, model: Any, data: Any, index: LoopIndex, tol: float = 1e-13, max_iter: int = 50
) -> float:
    """Solve the passive joints so every loop closes; returns the final gap in [m].

    Raises SimulationError if the gap stays above `tol` after `max_iter` Newton steps.
    """
    passive = list(index.passive_dof)
    gap = np.inf
    for _ in range(max_iter):
        mj.mj_kinematics(model, data)
        mj.mj_comPos(model, data)
        r = loop_residual(data, index).ravel()
        gap = float(np.abs(r).max())
        if gap <= tol:
            return gap
        step = np.linalg.lstsq(_jacobian(mj, model, data, index), -r, rcond=None)[0]
        data.qpos[passive] += step
    raise SimulationError(
        f"PCJM loops did not close: gap {gap:.3g} m after {max_iter} Newton steps "
        f"(tolerance {tol:.3g} m); sliders = {data.qpos[list(index.slider_qpos)]}"
    )


def assemble_at(
    mj: Any, model: Any, data: Any, index: LoopIndex, s: FloatArray, max_move: float = 2e-3
) -> float:
    """Move the sliders to s in steps of at most `max_move` [m], closing the loops after each.

    Small steps keep Newton on the assembly branch of the current pose (the loops also close
    with a stage turned by pi). Returns the final gap in [m].
    """
    sliders = list(index.slider_qpos)
    start = data.qpos[sliders].copy()
    n = max(1, int(np.ceil(np.abs(s[:4] - start[:4]).max() / max_move)))
    gap = 0.0
    for k in range(1, n + 1):
        data.qpos[sliders] = start + (s - start) * (k / n)
        gap = assemble(mj, model, data, index)
    return gap
