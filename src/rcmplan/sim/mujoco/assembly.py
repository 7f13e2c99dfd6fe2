"""Close the PCJM loops of a MuJoCo model: residual, loop-closure gap and Newton assembly.

The residual of each `connect` equality is the world-frame gap between the pin on the slider
and the pin riding in the stage slot. Assembly holds the slider joints and moves the passive
joints (stage guide, stage hinge, slot pins) by Gauss-Newton steps on MuJoCo's own kinematics
and Jacobians, so the closed loop is solved by the model, not by the planner's formulas.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

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
    slot = data.site_xpos[list(index.slot_sites)]
    pin = data.site_xpos[list(index.pin_sites)]
    return np.asarray(slot - pin, dtype=float)


def loop_gap(data: Any, index: LoopIndex) -> float:
    """Largest loop-closure gap in [m] at the current site positions."""
    return float(np.linalg.norm(loop_residual(data, index), axis=1).max())


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
