"""The view's side panels: the figures of the shown moment, and each actuator (iRAM!S slider
or arm joint) against its travel.

Lengths read in mm and um, angles in degrees; a value without meaning at that moment (the RCM
deviation in free space) reads "-".
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.analysis.units import fmt

STEPS = 1000  # slider resolution over an actuator's travel


class StatePanel:
    """A block of `name: value` lines, rewritten in one message per update.

    Args:
        gui: A viser GuiApi. title: The block's heading.
    """

    def __init__(self, gui: Any, title: str) -> None:
        self.title = title
        self.text = gui.add_markdown(f"**{title}**")
        self.values: dict[str, str] = {}

    def show(self, values: dict[str, str]) -> None:
        """Replace the lines."""
        self.values = dict(values)
        lines = [f"**{self.title}**", *(f"{k}: **{v}**" for k, v in values.items())]
        self.text.content = "  \n".join(lines)


class ActuatorPanel:
    """One read-only slider per actuator spanning its travel [lower, upper].

    Args:
        gui: A viser GuiApi. names: Actuator names. units: "m" or "rad" each.
        lower, upper: Travel in [m] or [rad]; NaN where unknown (the span of the log is used).
    """

    def __init__(
        self, gui: Any, names: Sequence[str], units: Sequence[str], lower: FloatArray,
        upper: FloatArray,
    ) -> None:  # fmt: skip
        self.factors = np.array([1e3 if u == "m" else 180.0 / np.pi for u in units])
        self.lower = np.asarray(lower, dtype=float) * self.factors
        self.upper = np.asarray(upper, dtype=float) * self.factors
        self.sliders = []
        for name, unit, lo, hi in zip(names, units, self.lower, self.upper, strict=True):
            label = f"{name} [{'mm' if unit == 'm' else 'deg'}]"
            step = float(hi - lo) / STEPS
            self.sliders.append(gui.add_slider(
                label, min=float(lo), max=float(hi), step=step, initial_value=float(lo),
                disabled=True, hint=f"travel {lo:.4g} .. {hi:.4g}",
            ))  # fmt: skip

    def show(self, s: FloatArray) -> None:
        """Show actuator positions s (n,) in [m] or [rad] (clipped to the drawn travel)."""
        v = np.clip(np.asarray(s, dtype=float) * self.factors, self.lower, self.upper)
        for slider, x in zip(self.sliders, v, strict=True):
            slider.value = float(x)


def travel(lower: FloatArray, upper: FloatArray, s: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Travel to draw per actuator: [lower, upper] where known, else the span of the positions
    s (N, n) (widened where they never move)."""
    lo = np.where(np.isfinite(lower), lower, np.min(s, axis=0))
    hi = np.where(np.isfinite(upper), upper, np.max(s, axis=0))
    same = hi - lo <= 0
    return lo - same * 1e-3, hi + same * 1e-3


def length(value: float, unit: str = "um") -> str:
    """A length in [m] for a panel, "-" for NaN."""
    return fmt(value, unit, with_unit=True)
