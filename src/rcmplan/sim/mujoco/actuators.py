"""Piezo stick-slip slider actuators: every actuator parameter in one frozen dataclass.

A stick-slip positioner in closed-loop (scanning) mode is modelled as a stiff position servo
that tracks a reference; the reference moves towards the quantised command no faster than the
slider's maximum speed and changes its speed no faster than its acceleration, as a positioner
controller's trajectory generator does (all six axes scaled together, so their profiles stay
synchronised and they arrive at the same time; `velocity_into`).
In MuJoCo each slider has two actuators: an integrator whose state is the reference
(force kp (ref - x) - kv x_dot, state clamped to the travel) and a velocity feed-forward
(force kv v_ref), so a constant-speed ramp is tracked without lag.
Travel, speed and resolution come from `IramisParameters`; the servo values are assumed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray, scalar, vector
from rcmplan.control.resolution import quantised
from rcmplan.robot.iramis import Iramis

INSERTION, ROTARY = 4, 5  # indices of L5 and q5 in s = (L1, L2, L3, L4, L5, q5)


@dataclass(frozen=True)
class PiezoParameters:
    """Slider actuator model (assumed values marked).

    Attributes:
        lower, upper: Travel of the six sliders in [m] ([rad] for q5); from the robot.
        speed: Maximum speed of each slider in [m/s] ([rad/s] for q5); from the robot.
        resolution: Linear step resolution in [m]; from the robot (assumed there).
        rotary_resolution: Resolution of q5 in [rad] (assumed: 1 urad).
        bandwidth: Servo natural frequency in [Hz] (assumed: 100 Hz).
        damping_ratio: Servo damping ratio (assumed: 1, critical).
        linear_mass: Effective mass seen by a linear slider servo in [kg] (assumed: 0.3 kg, the
            coupler-rotation mode of a PCJM; lighter values leave it underdamped).
        rotary_inertia: Effective inertia seen by the q5 servo in [kg m^2] (assumed: 1e-6).
        insertion_mass: Effective mass seen by the L5 servo in [kg] (assumed: 0.03 kg, the
            insertion stage and needle).
        ramp_time: Time in [s] the reference takes from rest to full speed (assumed: 30 ms);
            slider i accelerates at most at speed_i / ramp_time, the same fraction of its speed
            for every slider, so synchronised profiles stay synchronised. 0 lets the reference
            jump to any speed within one period (velocity steps).
    """

    lower: tuple[float, ...]
    upper: tuple[float, ...]
    speed: tuple[float, ...]
    resolution: float
    rotary_resolution: float = 1e-6
    bandwidth: float = 100.0
    damping_ratio: float = 1.0
    linear_mass: float = 0.3
    rotary_inertia: float = 1e-6
    insertion_mass: float = 0.03
    ramp_time: float = 0.03

    def __post_init__(self) -> None:
        for name in ("resolution", "rotary_resolution", "bandwidth"):
            scalar(name, getattr(self, name), 0.0, np.inf, low_open=True)
        for name in ("damping_ratio", "linear_mass", "rotary_inertia", "insertion_mass"):
            scalar(name, getattr(self, name), 0.0, np.inf, low_open=True)
        scalar("ramp_time", self.ramp_time, 0.0, 10.0)
        vector("lower", self.lower, 6)
        vector("upper", self.upper, 6)
        vector("speed", self.speed, 6)

    @classmethod
    def from_robot(cls, robot: Iramis, **overrides: float) -> PiezoParameters:
        """Travel, speed and resolution from the robot; any field may be overridden."""
        p = robot.params
        values: dict[str, Any] = {
            "lower": tuple(p.slider_lower),
            "upper": tuple(p.slider_upper),
            "speed": tuple(p.slider_speed),
            "resolution": p.slider_resolution,
        }
        return cls(**{**values, **overrides})

    def inertia(self) -> FloatArray:
        """Effective mass [kg] or inertia [kg m^2] per slider servo, (6,)."""
        out = np.full(6, self.linear_mass)
        out[INSERTION] = self.insertion_mass
        out[ROTARY] = self.rotary_inertia
        return out

    def kp(self) -> FloatArray:
        """Servo stiffness per slider in [N/m] ([N m/rad] for q5), (6,)."""
        w = 2.0 * math.pi * self.bandwidth
        return self.inertia() * w * w

    def kv(self) -> FloatArray:
        """Servo damping per slider in [N s/m] ([N m s/rad] for q5), (6,)."""
        w = 2.0 * math.pi * self.bandwidth
        return 2.0 * self.damping_ratio * self.inertia() * w

    def steps(self) -> FloatArray:
        """Resolution per slider, (6,)."""
        out = np.full(6, self.resolution)
        out[ROTARY] = self.rotary_resolution
        return out

    def quantise(self, s: FloatArray) -> FloatArray:
        """The command s (6,) rounded to the slider resolution (`control.resolution.quantised`),
        a new array."""
        out = np.empty(6)
        quantised(vector("s", s, 6), self.steps(), out)
        return out


@njit(cache=True, borrows=True)
def velocity_into(target: FloatArray, s_ref: FloatArray, v_prev: FloatArray, dt: float,
                  speed: FloatArray, ramp: float, v: FloatArray) -> None:  # fmt: skip
    """The reference velocity of one period of dt [s] into v (n,): from the reference s_ref,
    moving at v_prev, towards the (quantised) target, within speed and acceleration: the
    plants' control period (`compiled.advance`) calls it.

    1. Synchronised: arrive within the period, the whole vector scaled down so that no slider
       exceeds its speed (every slider arrives together, the slider-space path stays straight).
    2. Braking: the speed fraction sigma = max_i |v_i| / speed_i is capped so that the
       reference can still stop at the target while slowing by dt / ramp per period.
       From sigma such a stop covers sigma^2 ramp / 2 + sigma dt / 2 (in seconds at full
       speed), which must not exceed r = max_i |target_i - s_ref_i| / speed_i.
    3. Acceleration: the change v - v_prev is scaled as a whole so that no slider's speed
       changes by more than speed_i dt / ramp (the profiles stay synchronised).
    With ramp <= 0 only step 1 applies."""
    n = v.shape[0]
    excess, r = 0.0, 0.0
    for i in range(n):
        d = target[i] - s_ref[i]
        v[i] = d / dt
        excess = max(excess, abs(v[i]) / speed[i])
        r = max(r, abs(d) / speed[i])
    sigma = 0.0
    for i in range(n):
        if excess > 1.0:
            v[i] /= excess
        sigma = max(sigma, abs(v[i]) / speed[i])
    if ramp <= 0.0:
        return
    half = 0.5 * dt
    brake = (math.sqrt(half * half + 2.0 * ramp * r) - half) / ramp
    if sigma > brake:
        factor = brake / sigma
        for i in range(n):
            v[i] *= factor
    change = 0.0
    for i in range(n):
        v[i] -= v_prev[i]
        change = max(change, abs(v[i]) / speed[i])
    change = change * ramp / dt
    for i in range(n):
        if change > 1.0:
            v[i] /= change
        v[i] += v_prev[i]
