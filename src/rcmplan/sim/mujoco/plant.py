"""The MuJoCo plant: the closed-loop iRAM!S model behind the `Plant` interface.

Modes:
    kinematic: a command places the sliders exactly; the PCJM loops are closed by Newton steps
        on MuJoCo's kinematics (no dynamics, no actuators).
    dynamic: each `advance` runs dt / physics_dt physics steps; the piezo servo reference moves
        towards the quantised command at most at slider speed and acceleration, the sliders'
        profiles synchronised (`actuators.velocity_into`).
After every period the plant checks for NaN, MuJoCo warnings and the loop-closure gap and
raises SimulationError when the simulation has become unstable.

The plant simulates the robot alone without visual geoms (`files.physics_model`); `scene()`
poses the full scene (eye, visuals) for renders. With gravity compensation on (every moving
body has gravcomp 1) gravity is switched off in the compiled model instead, which gives the
same forces without MuJoCo's per-body gravcomp pass (`cancel_gravity`). A period costs ten
physics steps plus some 30 us of Python (commands within travel take a one-comparison path,
the checks read cached views of MuJoCo's arrays); with the `fast` extra a controller runs the
whole closed loop compiled instead (`rcmplan.compiled.mujoco_loop`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray, instance, scalar, vector
from rcmplan.exceptions import SimulationError
from rcmplan.robot.iramis import SLIDER_NAMES, Iramis
from rcmplan.scene.eye import Eye, EyePoints
from rcmplan.sim.mujoco.actuators import PiezoParameters
from rcmplan.sim.mujoco.assembly import LoopIndex, assemble_at, loop_gap
from rcmplan.sim.mujoco.files import load_model, mujoco_module, physics_model
from rcmplan.sim.mujoco.model import ModelOptions
from rcmplan.sim.mujoco.plant_checks import check_plant_args
from rcmplan.sim.mujoco.scene import EyePhantom, default_eye, phantom_of
from rcmplan.sim.mujoco.servo_plant import ServoIds, ServoPlant

JOINT_QPOS = ("q0", "q1", "q2", "q3", "L5", "q5")


class MujocoPlant(ServoPlant):
    """iRAM!S in MuJoCo, read and commanded through slider positions (`ServoPlant`).

    Args:
        robot: Kinematic model the MJCF is generated from (default: thesis iRAM!S).
        mode: "dynamic" (servo actuators, physics) or "kinematic" (sliders set directly).
        dt: Control period in [s] (default 1 ms, a 1 kHz controller).
        physics_dt: Physics timestep in [s]; dt must be a whole multiple of it.
        gravity_compensation: Cancel gravity on the robot bodies (default on).
        eye: The eye in the scene: a phantom, or a scene Eye (with `points` as target sites);
            default: the default scene eye and its points.
        points: Named eye points shown as sites when `eye` is a scene Eye.
        piezo: Actuator parameters (default: from the robot, assumed servo values).
        gap_limit: Loop-closure gap in [m] above which the simulation is declared unstable.
        needle_arc: (R [m], alpha [rad]) of a curved needle's arc, drawn after the shaft
            (visual only; the controller's model holds its kinematics), or None.
    """

    _ids: _Ids

    def __init__(
        self,
        robot: Iramis | None = None,
        mode: str = "dynamic",
        dt: float = 1e-3,
        physics_dt: float = 1e-4,
        gravity_compensation: bool = True,
        eye: EyePhantom | Eye | None = None,
        points: EyePoints | None = None,
        piezo: PiezoParameters | None = None,
        gap_limit: float = 50e-6,
        needle_arc: tuple[float, float] | None = None,
    ) -> None:
        check_plant_args(mode, gravity_compensation, eye, points, piezo, needle_arc)
        what = "an Iramis model or None (MujocoPlant simulates iRAM!S; make_plant for arms)"
        self.robot = Iramis() if robot is None else instance("robot", robot, Iramis, what)
        self.mj = mujoco_module()
        self.mode = mode
        self.name = f"mujoco-{mode}"
        # capabilities: a kinematic-mode command is reached exactly; a dynamic period can run
        # in compiled code (`rcmplan.sim.mujoco.compiled`)
        self.exact_commands = False
        self.compiled_physics = mode == "dynamic"
        physics_dt = self._timing(dt, physics_dt)
        self.gap_limit = scalar("gap_limit", gap_limit, 0.0, 1e-2, low_open=True)
        self.eye = (
            phantom_of(eye, points) if isinstance(eye, Eye) else eye or default_eye(self.robot)
        )
        self.piezo = piezo or PiezoParameters.from_robot(self.robot)
        options = ModelOptions(physics_dt=physics_dt, gravity_compensation=gravity_compensation,
                               needle_arc=needle_arc)  # fmt: skip
        self._options = options
        self.model = physics_model(self.robot, self.piezo, options)
        if gravity_compensation:
            cancel_gravity(self.mj, self.model)
        self.data = self.mj.MjData(self.model)
        self.index = LoopIndex.of(self.mj, self.model)
        self._ids = _Ids(self.mj, self.model)
        self._steps, self._speed = self.piezo.steps(), np.asarray(self.piezo.speed)
        self._ramp = float(self.piezo.ramp_time)
        # no clip of the command: the model clamps the servo's state to the travel
        self._clip = (np.full(6, -np.inf), np.full(6, np.inf))
        # capability: a dynamic-mode command is rounded to the slider resolution
        self.actuator_resolution = self._steps.copy() if mode == "dynamic" else None
        self._lower, self._upper = self.robot.lower, self.robot.upper
        self._warning_count = self.data.warning.number  # a view: MuJoCo updates it in place
        self.time = 0.0
        self._cmd = self.robot.home_actuators.copy()
        self.reset(self.robot.home_actuators)

    # --- Plant interface ---------------------------------------------------------------------
    def reset(self, s: FloatArray) -> None:
        """Place the sliders at s (closing the loops), at rest, and set the time to zero."""
        s = self.robot.check_actuators(vector("s", s, 6)).copy()
        self.mj.mj_resetData(self.model, self.data)
        assemble_at(self.mj, self.model, self.data, self.index, s)
        self.data.act[self._ids.act] = s
        self.mj.mj_forward(self.model, self.data)
        self._cmd = s
        self.time = 0.0

    def _place(self, s: FloatArray) -> None:
        """Kinematic mode: the sliders at s, the loops closed by Newton steps."""
        assemble_at(self.mj, self.model, self.data, self.index, s)

    # --- simulated measurements ------------------------------------------------------------
    def joints(self) -> FloatArray:
        """The simulated joint vector q = (q0..q5) read from the MuJoCo joints."""
        return np.array(self.data.qpos[self._ids.joint_qpos], dtype=float)

    def tip_position(self) -> FloatArray:
        """Needle tip site position (3,) in [m], base frame."""
        return np.array(self.data.site_xpos[self._ids.tip], dtype=float)

    def needle_base_position(self) -> FloatArray:
        """Needle base site position (3,) in [m], base frame."""
        return np.array(self.data.site_xpos[self._ids.base], dtype=float)

    def tip_pose(self) -> FloatArray:
        """Needle tip site pose (4, 4) in the base frame (compare Iramis.forward_kinematics)."""
        T = np.eye(4)
        T[:3, :3] = self.data.site_xmat[self._ids.tip].reshape(3, 3)
        T[:3, 3] = self.data.site_xpos[self._ids.tip]
        return T

    def _scene_model(self) -> Any:
        """The full scene (eye phantom, visual geoms, cameras) that `scene` poses."""
        return load_model(self.robot, self.eye, self.piezo, self._options)

    def loop_gap(self) -> float:
        """Largest PCJM loop-closure gap in [m]."""
        return loop_gap(self.data, self.index)

    def settle(self, duration: float = 0.2) -> None:
        """Hold the current command for `duration` [s]."""
        for _ in range(round(duration / self.dt)):
            self.advance()

    def _check_more(self) -> None:
        """SimulationError if a loop-closure gap is above `gap_limit`."""
        d = self.data
        r = d.site_xpos[self.index.slot_array]
        r -= d.site_xpos[self.index.pin_array]
        if float(r.ravel().dot(r.ravel())) <= self.gap_limit**2:  # bounds every pin's gap
            return
        gap = self.loop_gap()
        if gap > self.gap_limit:
            raise SimulationError(
                f"PCJM loop-closure gap {gap:.3g} m exceeds the limit {self.gap_limit:.3g} m "
                f"at t = {self.time:.6g} s (sliders {self.read_actuators()})"
            )

    def loop_sites(self) -> tuple[NDArray[np.intp], NDArray[np.intp], float]:
        """(slot sites, pin sites, gap limit [m]) of the PCJM loops (`ServoPlant`)."""
        return self.index.slot_array, self.index.pin_array, self.gap_limit


def cancel_gravity(mj: Any, model: Any) -> None:
    """Replace per-body gravity compensation by switching gravity off, in place.

    `gravcomp` 1 applies m g at every body's centre of mass, which cancels gravity exactly;
    when every body that can move carries it, turning gravity off gives the same forces and
    saves MuJoCo's gravcomp pass (about a tenth of a physics step for iRAM!S). A model with a
    moving body that is not compensated (a free object, say) is left unchanged.
    """
    moving = np.asarray(model.body_dofnum) > 0
    moving[0] = False
    parent = np.asarray(model.body_parentid)
    for b in range(1, model.nbody):  # a body moves when it or an ancestor has a dof
        moving[b] = moving[b] or moving[parent[b]]
    if not np.all(np.asarray(model.body_gravcomp)[moving] == 1.0):
        return
    model.opt.disableflags |= int(mj.mjtDisableBit.mjDSBL_GRAVITY)
    model.body_gravcomp[:] = 0.0


class _Ids(ServoIds):
    """Ids and addresses the plant reads every period: the sliders' (`ServoIds`), the needle's
    sites and the joints q."""

    def __init__(self, mj: Any, model: Any) -> None:
        super().__init__(mj, model, list(SLIDER_NAMES), list(SLIDER_NAMES))

        def obj(kind: Any, name: str) -> int:
            return int(mj.mj_name2id(model, kind, name))

        site, jnt = mj.mjtObj.mjOBJ_SITE, mj.mjtObj.mjOBJ_JOINT
        self.tip = obj(site, "needle_tip")
        self.base = obj(site, "needle_base")
        self.joint_qpos = np.array([int(model.jnt_qposadr[obj(jnt, n)]) for n in JOINT_QPOS])
