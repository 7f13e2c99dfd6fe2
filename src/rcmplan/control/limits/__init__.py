"""Limits: each gives linear rows over one control step's QP variables x (`base.py`).

`ActuatorLimit` gives variable bounds (travel and speed, lambda in [0, 1]); `RcmLimit`,
`RetinaBarrier`, `SingularMargin`, `TipSpeed`, and per solver `WorkspaceBound` (a box for the
tip) and `TissueDepthLimit` (a moving sphere the tip stays within) give inequality rows
G x <= h (the RCM, with tolerance 0, an equality A x = b). The QP
(`rcmplan.control.qp_problem`) is assembled from them.
"""

from rcmplan.control.limits.actuators import ActuatorLimit
from rcmplan.control.limits.base import Constraint, Kinematics, Limit, StepInput, kinematics
from rcmplan.control.limits.rcm import RcmLimit
from rcmplan.control.limits.retina import RetinaBarrier
from rcmplan.control.limits.singular import SingularMargin
from rcmplan.control.limits.tip_speed import TipSpeed
from rcmplan.control.limits.tissue_depth import TissueDepthLimit
from rcmplan.control.limits.workspace import WorkspaceBound

__all__ = [
    "ActuatorLimit",
    "Constraint",
    "Kinematics",
    "Limit",
    "RcmLimit",
    "RetinaBarrier",
    "SingularMargin",
    "StepInput",
    "TipSpeed",
    "TissueDepthLimit",
    "WorkspaceBound",
    "kinematics",
]
