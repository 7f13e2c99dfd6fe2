"""What the two MuJoCo plants share: actuators read and commanded as a vector (iRAM!S's sliders
in `MujocoPlant`, an arm's joints in `ArmPlant`), each a position servo whose reference moves
towards the quantised command with a velocity feed-forward.

`ServoPlant.advance` is the plants' control period. In dynamic mode it is the compiled period
the compiled loops run (`sim.mujoco.compiled.advance`, called here with this plant's arrays):
the command quantised to the actuator resolution and clipped (`_clip`: an arm's travel,
unbounded on iRAM!S), the reference velocity within speed and acceleration
(`actuators.velocity_into`; ramp 0: speed alone), the servo and feed-forward controls, the
physics steps through MuJoCo's C functions, the kinematics and the checks, whose failure
`check` then names. In kinematic mode the subclass places the actuators (`_place`), then
MuJoCo's kinematics and `check` (NaN, MuJoCo warnings, and the subclass's own: iRAM!S's
loop-closure gap, `_check_more`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray, scalar, vector
from rcmplan.exceptions import InvalidInputError, SimulationError


class ServoIds:
    """Addresses the plant reads every period, in actuator order: the actuators' positions in
    qpos (`reads`), the servos' states in act, the servo and feed-forward controls."""

    def __init__(self, mj: Any, model: Any, reads: list[str], servos: list[str]) -> None:
        def obj(kind: Any, name: str) -> int:
            return int(mj.mj_name2id(model, kind, name))

        act, jnt = mj.mjtObj.mjOBJ_ACTUATOR, mj.mjtObj.mjOBJ_JOINT
        self.reads = np.array([int(model.jnt_qposadr[obj(jnt, n)]) for n in reads])
        self.servo = np.array([obj(act, f"servo_{n}") for n in servos])
        self.feedforward = np.array([obj(act, f"feedforward_{n}") for n in servos])
        self.act = np.array([int(model.actuator_actadr[i]) for i in self.servo])


class ServoPlant:
    """The Plant interface of a MuJoCo model with servo actuators; see the module docstring.

    A subclass sets, before its first `reset`: mj, model, data, robot, mode ("dynamic" or
    "kinematic"), dt [s], substeps (physics steps per period), `_ids` (`ServoIds`), `_steps`
    and `_speed` (the actuators' resolution and speed), `_ramp` [s] (0: no acceleration
    bound), `_clip` (lower, upper) of the quantised command, `_lower`, `_upper` (the travel a
    command is checked against), `_warning_count` (`data.warning.number`), and defines
    `_place` (kinematic mode), `reset` and `_scene_model` (what `scene` draws).
    """

    mj: Any
    model: Any
    data: Any
    robot: Any
    mode: str
    dt: float
    substeps: int
    time: float
    _ids: ServoIds
    _steps: FloatArray
    _speed: FloatArray
    _ramp: float
    _clip: tuple[FloatArray, FloatArray]
    _lower: FloatArray
    _upper: FloatArray
    _cmd: FloatArray
    _warning_count: NDArray[np.int32]  # a view of mjData's warning counts (MuJoCo updates it)
    _period: tuple[Any, tuple[Any, ...]] | None = None  # the compiled period and its arguments
    _scene: tuple[Any, Any] | None = None  # the scene's (MjModel, MjData), made when first asked

    def _scene_model(self) -> Any:
        """The MjModel of the scene a camera sees (the subclass's)."""
        raise NotImplementedError

    def scene(self) -> tuple[Any, Any]:
        """(MjModel, MjData) of the scene a camera sees (`_scene_model`: the physics model
        with the eye, visual geometry and cameras), posed at the plant's state, for rendering;
        `model` and `data` are the physics."""
        if self._scene is None:
            model = self._scene_model()
            self._scene = (model, self.mj.MjData(model))
        model, data = self._scene
        d = self.data
        data.qpos[:], data.qvel[:], data.act[:], data.ctrl[:] = d.qpos, d.qvel, d.act, d.ctrl
        data.time = d.time
        self.mj.mj_forward(model, data)
        return model, data

    def _timing(self, dt: float, physics_dt: float) -> float:
        """Check and set the control period dt [s] and the physics steps per period; returns
        physics_dt [s], which must divide dt."""
        self.dt = scalar("dt", dt, 0.0, 1.0, low_open=True)
        physics_dt = scalar("physics_dt", physics_dt, 0.0, dt, low_open=True)
        self.substeps = round(dt / physics_dt)
        if abs(self.substeps * physics_dt - dt) > 1e-9 * dt:
            raise InvalidInputError("physics_dt", physics_dt, f"a whole fraction of dt = {dt:g} s")
        return physics_dt

    def read_actuators(self) -> FloatArray:
        """The simulated actuator positions (n,) in [m] or [rad]."""
        return np.array(self.data.qpos[self._ids.reads], dtype=float)

    def command_actuators(self, s: FloatArray) -> None:
        """Command the actuators; SliderLimitError beyond travel, InvalidInputError if not
        finite or not (n,)."""
        n = self._steps.shape[0]
        try:
            cmd = np.array(s, dtype=np.float64)
            ok = cmd.shape == (n,) and bool(((cmd >= self._lower) & (cmd <= self._upper)).all())
        except (TypeError, ValueError):
            ok = False
        if not ok:  # NaN fails the comparison too; the full check names what is wrong
            cmd = self.robot.check_actuators(vector("s", s, n)).copy()
        self._cmd = cmd

    def advance(self) -> None:
        """Move on by one control period dt; raises SimulationError if unstable."""
        if self.mode == "kinematic":
            self._place(self._cmd)
            self.data.time += self.dt
            self.mj.mj_kinematics(self.model, self.data)
            self.time += self.dt
            self.check()
            return
        period, args = self._period or self._compiled_period()
        code = period(self._cmd, *args)
        self.time += self.dt
        if code != 0:  # `compiled.OK`
            from rcmplan.sim.mujoco import compiled

            self.check()  # names what failed
            failed = compiled.CHECKS.get(code, f"check {code}")
            raise SimulationError(f"the control period failed ({failed}) at t = {self.time:.6g} s")

    def _compiled_period(self) -> tuple[Any, tuple[Any, ...]]:
        """`compiled.advance` and its arguments after the command: its scratch, then this
        plant's arrays (`compiled.plant_arrays`), made once: views of mjData, which stays the
        same. (Imported here: it loads numba, which only the dynamic plant needs.)"""
        from rcmplan.sim.mujoco import compiled

        arrays = compiled.plant_arrays(self)
        if arrays is None:
            raise SimulationError(
                "the dynamic MuJoCo plant needs MuJoCo's C functions (mj_step, "
                f"mj_kinematics), and no MuJoCo library was found beside {self.mj.__file__}"
            )
        self._period = (compiled.advance, (np.empty((4, self._steps.shape[0])), *arrays.args()))
        return self._period

    def _place(self, s: FloatArray) -> None:
        """Kinematic mode: put the actuators exactly at s."""
        raise NotImplementedError

    @property
    def command(self) -> FloatArray:
        """The last actuator command (n,), a copy."""
        return self._cmd.copy()

    def warnings(self) -> dict[str, int]:
        """MuJoCo warning counters that are non-zero, by warning name."""
        counts = np.asarray(self.data.warning.number)
        if not counts.any():
            return {}
        names = {int(w): w.name for w in self.mj.mjtWarning.__members__.values()}
        return {names[int(i)]: int(counts[i]) for i in np.flatnonzero(counts)}

    def check(self) -> None:
        """Raise SimulationError if the simulation is unstable now: NaN or inf in the state,
        a MuJoCo warning, or the subclass's own check (`_check_more`)."""
        d = self.data
        if not math.isfinite(float(d.qpos.dot(d.qpos) + d.qvel.dot(d.qvel))):
            raise SimulationError(f"simulation diverged (NaN or inf) at t = {self.time:.6g} s")
        if self._warning_count.any():
            raise SimulationError(f"MuJoCo warnings at t = {self.time:.6g} s: {self.warnings()}")
        self._check_more()

    def _check_more(self) -> None:
        """A subclass's own stability check (nothing here)."""

    def loop_sites(self) -> tuple[NDArray[np.intp], NDArray[np.intp], float]:
        """(slot sites, pin sites, gap limit [m]) of the closed kinematic loops the compiled
        period checks (`sim.mujoco.compiled.advance`); none here."""
        none = np.empty(0, dtype=np.intp)
        return none, none, 0.0
