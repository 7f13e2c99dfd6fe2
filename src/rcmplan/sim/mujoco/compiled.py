"""The dynamic MuJoCo plants' control period in compiled code.

`advance` is the control period of a dynamic `MujocoPlant` (iRAM!S's sliders) or `ArmPlant`
(an arm's joints), the one implementation: the plant's own `advance` calls it, and so do the
compiled loops. The quantised command (clipped to travel, the arm's), the synchronised
reference velocity within speed and acceleration (`actuators.velocity_into`; the arm's
without the acceleration bound), the servo and feed-forward controls, the physics steps, the
kinematics and the checks (NaN, MuJoCo warnings, loop-closure gap: iRAM!S's PCJMs). MuJoCo's
own `mj_step` and `mj_kinematics` are called from the compiled code through their C
addresses, so a closed control loop on the MuJoCo plant runs without returning to Python
between periods (`rcmplan.compiled.algorithm`). tests/test_fast_mujoco.py and
tests/test_mujoco_arm.py check that a phase run by the compiled loop gives the same log, to
the last bit, as the loop stepping the plant from Python.

The C addresses come from the shared library the `mujoco` package loaded; they are arguments,
not constants, so numba's cache stays valid across processes.
"""

from __future__ import annotations

import ctypes
import functools
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic
from numpy.typing import NDArray

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.control.resolution import quantised
from rcmplan.sim.mujoco.actuators import velocity_into

OK, DIVERGED, WARNED, GAP = range(4)  # status codes of `advance`
CHECKS = {DIVERGED: "NaN or inf in the state", WARNED: "a MuJoCo warning", GAP: "a loop gap"}
LIBRARY_PATTERNS = {"linux": "libmujoco.so*", "darwin": "libmujoco*.dylib", "win32": "mujoco*.dll"}


def _call_model_data(typingctx: Any, fn: Any, model: Any, data: Any) -> Any:
    """call_model_data(fn, model, data) calls the C function `void fn(const mjModel*,
    mjData*)` at address fn (all three are addresses, as integers)."""
    sig = types.void(types.intp, types.intp, types.intp)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        ptr = ir.IntType(8).as_pointer()
        fnty = ir.FunctionType(ir.VoidType(), [ptr, ptr])
        f = builder.inttoptr(args[0], fnty.as_pointer())
        builder.call(f, [builder.inttoptr(args[1], ptr), builder.inttoptr(args[2], ptr)])
        return context.get_dummy_value()

    return sig, codegen


call_model_data: Any = intrinsic(_call_model_data)


def library_path(mj: Any) -> Path | None:
    """The MuJoCo shared library inside the `mujoco` package, or None if there is none."""
    pattern = next((p for key, p in LIBRARY_PATTERNS.items() if sys.platform.startswith(key)), "")
    found = sorted(Path(mj.__file__).parent.glob(pattern)) if pattern else []
    return found[0] if found else None


@functools.cache
def function_addresses(mj: Any) -> tuple[int, int] | None:
    """C addresses of (mj_step, mj_kinematics) in the library `mj` uses, or None; looked up
    once per process (every phase on the plant asks)."""
    path = library_path(mj)
    if path is None:
        return None
    lib = ctypes.CDLL(str(path))  # already loaded by the bindings: the same instance
    return tuple(int(ctypes.cast(getattr(lib, n), ctypes.c_void_p).value or 0)  # type: ignore[return-value]
                 for n in ("mj_step", "mj_kinematics"))  # fmt: skip


@dataclass(frozen=True)
class PlantArrays:
    """Everything `advance` reads or writes, as views of one MuJoCo plant's data.

    Attributes:
        fns: Addresses (mj_step, mj_kinematics); model, data: of the plant's MjModel/MjData.
        substeps: Physics steps per control period; dt: the control period [s].
        steps, speed: Actuator resolution and speed (n,); ramp: the reference's time from rest
            to full speed [s] (`PiezoParameters.ramp_time`; 0 for an arm); gap2: the loop-gap
            limit squared [m^2] (no loops on an arm: `slot` and `pin` empty).
        lower, upper: The quantised command's clip (n,): an arm's travel, +-inf on iRAM!S
            (whose plant does not clip).
        act, ctrl, qpos, qvel, xpos, warn: Views of mjData's arrays (MuJoCo writes into them).
        act_idx, servo, feedforward, slider_qpos, slot, pin: Index arrays into those views.
    """

    fns: NDArray[np.intp]
    model: int
    data: int
    substeps: int
    dt: float
    steps: FloatArray
    speed: FloatArray
    ramp: float
    gap2: float
    lower: FloatArray
    upper: FloatArray
    act: FloatArray
    ctrl: FloatArray
    qpos: FloatArray
    qvel: FloatArray
    xpos: FloatArray
    warn: NDArray[np.int32]
    act_idx: NDArray[np.intp]
    servo: NDArray[np.intp]
    feedforward: NDArray[np.intp]
    slider_qpos: NDArray[np.intp]
    slot: NDArray[np.intp]
    pin: NDArray[np.intp]

    def args(self) -> tuple[Any, ...]:
        """The arguments of `advance` after the command, in order."""
        return (self.fns, self.model, self.data, self.substeps, self.dt, self.steps,
                self.speed, self.ramp, self.gap2, self.lower, self.upper, self.act, self.ctrl,
                self.qpos, self.qvel, self.xpos, self.warn, self.act_idx, self.servo,
                self.feedforward, self.slot, self.pin)  # fmt: skip

    def loop_args(self) -> tuple[Any, ...]:
        """The plant argument of the compiled loop (`algorithm.run_targets`): the indices of
        the actuators' positions in qpos, then `args`."""
        return (self.slider_qpos, *self.args())


def exact_plant() -> tuple[Any, ...]:
    """The compiled loop's plant argument for the kinematic plant, which reaches each command
    exactly: model address 0 and empty arrays, of the types `PlantArrays.loop_args` has (one
    compiled loop serves both plants)."""
    i, f = np.empty(0, dtype=np.intp), np.empty(0)
    warn = np.zeros(4, dtype=np.int32)[::2]  # mjData's warning counts: a strided view
    return (i, i, 0, 0, 0, 0.0, f, f, 0.0, 0.0, f, f, f, f, f, f, np.empty((0, 3)), warn, i, i, i,
            i, i)  # fmt: skip


def stepping_plant() -> tuple[Any, ...]:
    """The compiled loop's plant argument for a plant that steps in Python: `exact_plant` with
    model address -1, so that the loop returns after each iteration (`algorithm.run_targets`)
    for its driver to command and advance the plant."""
    exact = exact_plant()
    return (*exact[:2], -1, *exact[3:])


def plant_arrays(plant: Any) -> PlantArrays | None:
    """The arrays of a dynamic `ServoPlant` (`MujocoPlant`, `ArmPlant`), or None if MuJoCo's C
    functions cannot be found."""
    fns = function_addresses(plant.mj)
    if fns is None or not all(fns):
        return None
    d, ids = plant.data, plant._ids
    slot, pin, gap = plant.loop_sites()

    def idx(a: Any) -> NDArray[np.intp]:
        return np.ascontiguousarray(a, dtype=np.intp)

    def arr(a: Any) -> FloatArray:
        return np.ascontiguousarray(a, dtype=np.float64)

    return PlantArrays(
        fns=np.array(fns, dtype=np.intp), model=int(plant.model._address),
        data=int(d._address), substeps=int(plant.substeps), dt=float(plant.dt),
        steps=arr(plant._steps), speed=arr(plant._speed), ramp=float(plant._ramp),
        gap2=float(gap) ** 2, lower=arr(plant._clip[0]), upper=arr(plant._clip[1]), act=d.act,
        ctrl=d.ctrl, qpos=d.qpos, qvel=d.qvel, xpos=d.site_xpos, warn=d.warning.number,
        act_idx=idx(ids.act), servo=idx(ids.servo), feedforward=idx(ids.feedforward),
        slider_qpos=idx(ids.reads), slot=idx(slot), pin=idx(pin),
    )  # fmt: skip


@njit(cache=True, borrows=True)
def reference_velocity(
    cmd: FloatArray, v: FloatArray, dt: float, steps: FloatArray, speed: FloatArray,
    ramp: float, lower: FloatArray, upper: FloatArray, act: FloatArray,
    act_idx: NDArray[np.intp], ctrl: FloatArray, servo: NDArray[np.intp],
) -> None:  # fmt: skip
    """v[0] (n,) = `actuators.velocity_into` towards the quantised command cmd (n,), clipped
    to [lower, upper], from the servo references act[act_idx], moving at the last period's
    ctrl[servo]; v (4, n): the velocity, then the quantised command, the references and the
    last velocities."""
    quantised(cmd, steps, v[1])
    for i in range(cmd.shape[0]):
        v[1, i] = min(max(v[1, i], lower[i]), upper[i])
        v[2, i] = act[act_idx[i]]
        v[3, i] = ctrl[servo[i]]
    velocity_into(v[1], v[2], v[3], dt, speed, ramp, v[0])


@njit(cache=True, borrows=True)
def advance(
    cmd: FloatArray, v: FloatArray, fns: NDArray[np.intp], model: int, data: int,
    substeps: int, dt: float, steps: FloatArray, speed: FloatArray, ramp: float, gap2: float,
    lower: FloatArray, upper: FloatArray, act: FloatArray, ctrl: FloatArray, qpos: FloatArray,
    qvel: FloatArray, xpos: FloatArray,
    warn: NDArray[np.int32], act_idx: NDArray[np.intp], servo: NDArray[np.intp],
    feedforward: NDArray[np.intp], slot: NDArray[np.intp], pin: NDArray[np.intp],
) -> int:  # fmt: skip
    """One control period of the dynamic plant towards the command cmd (n,); v (4, n) is
    scratch. Returns OK or the first failing check (DIVERGED, WARNED, GAP)."""
    reference_velocity(cmd, v, dt, steps, speed, ramp, lower, upper, act, act_idx, ctrl, servo)
    for i in range(cmd.shape[0]):
        ctrl[servo[i]] = v[0, i]
        ctrl[feedforward[i]] = v[0, i]
    for _ in range(substeps):
        call_model_data(fns[0], model, data)
    call_model_data(fns[1], model, data)
    total = 0.0
    for x in qpos:
        total += x * x
    for x in qvel:
        total += x * x
    if not np.isfinite(total):
        return DIVERGED
    for n in warn:
        if n != 0:
            return WARNED
    for k in range(slot.shape[0]):
        g = 0.0
        for j in range(3):
            r = xpos[slot[k], j] - xpos[pin[k], j]
            g += r * r
        if g > gap2:
            return GAP
    return OK
