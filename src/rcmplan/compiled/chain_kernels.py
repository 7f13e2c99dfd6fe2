"""The compiled kernels of any serial arm holding a straight needle, gathered for
`rcmplan.compiled.cache.chain_kernels`: kinematics (`chain_kinematics`, which also states the
memory layout), the singularity measure (`chain_singular`), steps (`chain_solve`) and checks
(`chain_checks`).

The same maths as `SerialArm` (`robot/model.py`, which calls `chain_kinematics`), the
X_ext stacking (`control/augmented.py`) and `PinvSolver` / `DlsSolver` (`control/solvers.py`),
so results agree with the reference to rounding. Imports numba (the `fast` extra); loaded only
through `rcmplan.compiled.cache.chain_kernels`.
"""

from rcmplan.compiled.chain_checks import screen_targets
from rcmplan.compiled.chain_solve import (
    dls_solve_at,
    dls_step,
    gram_solve,
    pinv_solve,
    pinv_step,
)
from rcmplan.robot.chain_kinematics import (
    AXIS,
    ROWS,
    SING,
    TIP,
    E,
    F,
    IntArray,
    X,
    Z,
    angle_rows,
    axes_row,
    blank_work,
    compose,
    evaluate,
    frames,
    holds_frames,
    jacobian_at,
    joint_axis,
    move,
    needle_axis,
    needle_point,
    point_jacobian,
    rotate,
    task_at,
    task_jacobian,
    work_shape,
)
from rcmplan.robot.chain_pose import needle_pose
from rcmplan.robot.chain_singular import (
    CERTIFY,
    gram_extremes,
    is_singular,
    singular_gram,
    singular_terms,
    singularity_measure,
)

__all__ = [
    "AXIS",
    "CERTIFY",
    "ROWS",
    "SING",
    "TIP",
    "E",
    "F",
    "IntArray",
    "X",
    "Z",
    "angle_rows",
    "axes_row",
    "blank_work",
    "compose",
    "dls_solve_at",
    "dls_step",
    "evaluate",
    "frames",
    "gram_extremes",
    "gram_solve",
    "holds_frames",
    "is_singular",
    "jacobian_at",
    "joint_axis",
    "move",
    "needle_axis",
    "needle_point",
    "needle_pose",
    "pinv_solve",
    "pinv_step",
    "point_jacobian",
    "rotate",
    "screen_targets",
    "singular_gram",
    "singular_terms",
    "singularity_measure",
    "task_at",
    "task_jacobian",
    "work_shape",
]
