"""Plants a controller can drive: the kinematic plant here, MuJoCo in `rcmplan.sim.mujoco`."""

from rcmplan.control.plant import Plant
from rcmplan.sim.kinematic import KinematicPlant

__all__ = ["KinematicPlant", "Plant"]
