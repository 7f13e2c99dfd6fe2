"""The controller bounds its own step from the stated RCM tolerance.

A step of the augmented Jacobian (or of DLS, or of the QP) moves the RCM point to first order
exactly where the task asks, onto the trocar; what it leaves is second order in the step's
length (the needle's rotation bends the path of every point of it). So the deviation after a
step shrinks with the square of a factor applied to it: a step that would leave the needle
farther than the bound from the trocar is scaled by 0.9 sqrt(bound / deviation) and tried
again, at most STEP_TRIES times, and a step that leaves it no farther than it was is kept
(the loop then converges from where it stands). The loop tolerance then takes more iterations
per target where a robot turns the needle through long levers, instead of needing smaller
target steps from the plan.

`step_scale` is the one rule; the compiled loops call it in compiled code and the Python loop
calls it as it is (a numba kernel).
"""

from __future__ import annotations

import math

from numba import njit

STEP_TRIES = 4  # the scaled step is tried again at most this many times
SHRINK_FLOOR = 0.1  # no single try shrinks a step by more than this factor


@njit(cache=True)
def step_scale(after: float, before: float, bound: float) -> float:
    """1.0 if a step leaves the needle within `bound` [m] of the trocar, or no farther than
    `before` [m]; else the factor (at least SHRINK_FLOOR) that brings a deviation `after` [m],
    second order in the step, to 0.9 bound."""
    if after <= bound or after <= before:
        return 1.0
    return max(SHRINK_FLOOR, 0.9 * math.sqrt(bound / after))
