"""Plants a controller can drive: the kinematic plant here, MuJoCo in `rcmplan.sim.mujoco`."""

from rcmplan.sim.kinematic import KinematicPlant
from rcmplan.sim.plant import Plant

__all__ = ["KinematicPlant", "Plant"]
