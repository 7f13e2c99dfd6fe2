"""Algorithm 1 closed around the dynamic MuJoCo plant, all in compiled code.

The phase runs in the one compiled loop (`algorithm.run_targets`, through
`phase.run_phase_compiled`) given the plant's arrays: each control period it reads the
simulated sliders, runs one iteration of Algorithm 1 (`loop.iterate`; the QP's planned from the
plant's last command, the plant being its servo) and, when it steps, runs the plant's period
(`sim.mujoco.compiled.advance`: the physics steps through MuJoCo's C functions). Python is back
only between record blocks and at the end, so a period costs the physics and about a
microsecond more. The log, the plant's state and the stops equal those of the per-iteration
path (`phase.run_phase_on_plant`); tests/test_fast_mujoco.py checks it bit for bit, and
tests/test_qp_mujoco_compiled.py the QP's against the Python QP on the same plant.
Needs MuJoCo (the `sim` extra).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

from rcmplan._validate import FloatArray
from rcmplan.compiled.phase import run_phase_compiled
from rcmplan.control.solvers import Solver
from rcmplan.sim.mujoco.compiled import PlantArrays, plant_arrays

if TYPE_CHECKING:
    from rcmplan.control.runner import ControlState as Controller
    from rcmplan.sim.mujoco.plant import MujocoPlant


def run_phase_on_mujoco(
    controller: Controller, solver: Solver, targets: FloatArray, pid: int, sid: int,
    arrays: PlantArrays | None = None, P: FloatArray | None = None,
) -> bool:  # fmt: skip
    """Algorithm 1 on each target with the dynamic MuJoCo plant, compiled; False (nothing
    done) if MuJoCo's C functions cannot be found. See the module docstring. P: the kernels'
    parameters (default: iRAM!S's own; a curved needle's carry its arc, `curved_iramis.params`,
    and its records the roll error)."""
    arrays = arrays or plant_arrays(cast("MujocoPlant", controller.plant))
    if arrays is None:
        return False
    run_phase_compiled(controller, solver, targets, pid, sid, P, arrays)
    return True
