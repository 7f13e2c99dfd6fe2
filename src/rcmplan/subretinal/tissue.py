"""Retinal deformation before puncture: the needle tents the ILM, then passes through it.

Quasi-static, along the local normal. Let z be the tip's depth below the undeformed (but
physiologically moved) ILM [m], positive into the tissue. While z <= 0 the tip is in the
vitreous. Once it touches the ILM and pushes on, the ILM under the tip moves with it (tenting):
the tenting displacement is delta = z and the contact force F(delta) follows a stiffness law,

    linear:      F = k delta
    exponential: F = k l (exp(delta / l) - 1)     (stiffening; tends to k delta as l -> inf)

with k the initial stiffness [N/m] and l the stiffening length [m]. When F reaches the puncture
force F_p the tip passes the ILM, the tent relaxes and the tip sits at depth z in the tissue:
the depth in tissue jumps from 0 to delta_p = F^-1(F_p). A punctured ILM stays punctured for
the episode. Sources of the defaults (assumed, within published retinal tip forces):
docs/subretinal.md.

States per episode (`TissueContact`): APPROACH (tip in the vitreous, no contact), TENTING (in
contact, pushing the ILM ahead of it, F < F_p), PUNCTURED (tip through the ILM).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray, array, scalar
from rcmplan.exceptions import InvalidInputError


class TissueState(IntEnum):
    """Contact state of the needle tip with the ILM."""

    APPROACH = 0
    TENTING = 1
    PUNCTURED = 2


@dataclass(frozen=True)
class TissueModel:
    """Stiffness and puncture threshold of the ILM under a needle tip.

    Attributes:
        stiffness_n_per_m: Initial stiffness k [N/m] (assumed 50 N/m: a 100 um tent at 5 mN).
        puncture_force_n: Force F_p [N] at which the tip passes the ILM (assumed 5 mN).
        stiffening_length_m: l [m] of the exponential law; None for the linear law.
        tent_width_m: Standard deviation [m] of the Gaussian dent the tent makes laterally
            (assumed; used by the B-scan renderer).
        rpe_coupling: Fraction of the tenting displacement the RPE follows (assumed).
    """

    stiffness_n_per_m: float = 50.0
    puncture_force_n: float = 5e-3
    stiffening_length_m: float | None = None
    tent_width_m: float = 150e-6
    rpe_coupling: float = 0.2

    def __post_init__(self) -> None:
        scalar("stiffness_n_per_m", self.stiffness_n_per_m, 0.0, 1e5, low_open=True)
        scalar("puncture_force_n", self.puncture_force_n, 0.0, 1.0, low_open=True)
        if self.stiffening_length_m is not None:
            scalar("stiffening_length_m", self.stiffening_length_m, 1e-6, 1e-2)
        scalar("tent_width_m", self.tent_width_m, 1e-6, 5e-3)
        scalar("rpe_coupling", self.rpe_coupling, 0.0, 1.0)

    def force_n(self, tent_m: Any) -> Any:
        """Contact force F [N] at tenting displacements delta [m] (a float or an array; a
        negative delta is no contact, F = 0)."""
        delta = np.maximum(0.0, tent_m)
        k, length = self.stiffness_n_per_m, self.stiffening_length_m
        if length is None:
            return k * delta
        return k * length * np.expm1(delta / length)

    def tent_for_force_m(self, force_n: float) -> float:
        """Tenting displacement delta [m] at a force F >= 0 [N]: the inverse of `force_n`."""
        f = max(0.0, force_n)
        k, length = self.stiffness_n_per_m, self.stiffening_length_m
        if length is None:
            return f / k
        return length * math.log1p(f / (k * length))

    @property
    def puncture_tent_m(self) -> float:
        """Tenting displacement delta_p [m] at which the ILM gives way."""
        return self.tent_for_force_m(self.puncture_force_n)


class TissueReading(NamedTuple):
    """The tissue's answer to one tip position.

    Attributes:
        state: The contact state after this position.
        tent_m: Tenting displacement of the ILM under the tip [m] (0 unless TENTING).
        force_n: Contact force on the tip [N] (0 unless TENTING).
        depth_in_tissue_m: Tip depth below the ILM as it is (tented or not) [m]: 0 while
            tenting, the depth below the undeformed ILM once punctured, negative in the vitreous.
        depth_vs_undeformed_m: Tip depth below the undeformed ILM [m] (the input).
        punctured_now: True at the one update where the ILM gave way.
    """

    state: TissueState
    tent_m: float
    force_n: float
    depth_in_tissue_m: float
    depth_vs_undeformed_m: float
    punctured_now: bool


class TissueContact:
    """The contact state machine of one episode (module docstring)."""

    def __init__(self, model: TissueModel | None = None) -> None:
        self.model = model or TissueModel()
        self.state = TissueState.APPROACH

    def update(self, depth_vs_undeformed_m: float) -> TissueReading:
        """Advance to a tip depth below the undeformed ILM [m] and read the tissue."""
        z = scalar("depth_vs_undeformed_m", depth_vs_undeformed_m, -0.05, 0.05)
        states, tent, force, depth, first = self.read(np.array([z]))
        return TissueReading(TissueState(states[0]), float(tent[0]), float(force[0]),
                             float(depth[0]), z, first == 0)  # fmt: skip

    def read(
        self, depths_vs_undeformed_m: FloatArray
    ) -> tuple[NDArray[np.int64], FloatArray, FloatArray, FloatArray, int]:
        """Advance through tip depths below the undeformed ILM (n,) [m], in turn: per depth the
        state after it, the tent [m], the force [N] and the depth in tissue [m] (as
        `TissueReading`), and the index at which the ILM gave way (-1: not in these)."""
        z = array("depths_vs_undeformed_m", depths_vs_undeformed_m, 1)
        if z.size and (z.min() < -0.05 or z.max() > 0.05):
            bad = z[np.argmax(np.abs(z))]
            raise InvalidInputError("depths_vs_undeformed_m", float(bad), "[-0.05, 0.05] m")
        force = self.model.force_n(z)
        states = np.where(z <= 0.0, TissueState.APPROACH, TissueState.TENTING).astype(np.int64)
        first = -1
        if self.state == TissueState.PUNCTURED:
            states[:] = TissueState.PUNCTURED
        else:  # the ILM gives way at the first depth in contact whose force reaches F_p
            gives = np.flatnonzero((z > 0.0) & (force >= self.model.puncture_force_n))
            if gives.size:
                first = int(gives[0])
                states[first:] = TissueState.PUNCTURED
        tenting = states == TissueState.TENTING
        if z.size:
            self.state = TissueState(states[-1])
        return (states, np.where(tenting, z, 0.0), np.where(tenting, force, 0.0),
                np.where(tenting, 0.0, z), first)  # fmt: skip
