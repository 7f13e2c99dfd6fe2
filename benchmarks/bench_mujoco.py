"""MuJoCo plant figures: physics speed, real-time factor, kinematic agreement, the injection.

Run alone: MUJOCO_GL=egl python benchmarks/bench_mujoco.py
Each row: figure, value, unit, target. Speeds are medians of three runs on this machine.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np

from rcmplan import Iramis
from rcmplan.sim.mujoco.actuators import PiezoParameters
from rcmplan.sim.mujoco.plant import MujocoPlant

Row = tuple[str, str, str, str]
SEED = 20180507


def median_of_three(fn: Callable[[], float]) -> float:
    return statistics.median(fn() for _ in range(3))


def physics_steps_per_second(plant: MujocoPlant, n: int = 20000) -> float:
    def once() -> float:
        t = time.perf_counter()
        mujoco.mj_step(plant.model, plant.data, nstep=n)
        return n / (time.perf_counter() - t)

    plant.reset(plant.robot.home_sliders)
    return median_of_three(once)


def plant_real_time_factor(
    plant: MujocoPlant, seconds: float = 2.0, clock: Callable[[], float] = time.perf_counter
) -> float:
    """Simulated over elapsed time (wall or CPU `clock`) for `advance` with a new random
    command every 10 ms."""
    robot, rng = plant.robot, np.random.default_rng(SEED)

    def once() -> float:
        plant.reset(robot.home_sliders)
        t = clock()
        for k in range(round(seconds / plant.dt)):
            if k % 10 == 0:
                plant.command_sliders(rng.uniform(0.5 * robot.lower, 0.5 * robot.upper))
            plant.advance()
        return seconds / (clock() - t)

    return median_of_three(once)


def angle(Ra: np.ndarray, Rb: np.ndarray) -> float:
    M = Ra.T @ Rb
    w = 0.5 * np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]])
    return math.atan2(float(np.linalg.norm(w)), 0.5 * (float(np.trace(M)) - 1.0))


def agreement(plant: MujocoPlant, n: int, settle: float = 0.0) -> tuple[float, float, float]:
    """Worst (tip position error [m], tip angle error [rad], loop gap [m]) over n settings."""
    robot, rng = plant.robot, np.random.default_rng(SEED)
    worst = np.zeros(3)
    for _ in range(n):
        s = rng.uniform(robot.lower, robot.upper)
        if settle:  # start 1 mm away, move, settle
            plant.reset(np.clip(s - 1e-3, robot.lower, robot.upper))
            plant.command_sliders(s)
            plant.settle(settle)
        else:
            plant.reset(s)
        T = robot.forward_kinematics(robot.joints_from_sliders(plant.read_sliders()))
        Ts = plant.tip_pose()
        err = (np.linalg.norm(Ts[:3, 3] - T[:3, 3]), angle(Ts[:3, :3], T[:3, :3]), plant.loop_gap())
        worst = np.maximum(worst, err)
    return float(worst[0]), float(worst[1]), float(worst[2])


def injection(plant_name: str) -> dict[str, Any]:
    """The default injection on a dynamic MuJoCo plant via rcmplan.job.run_scenario."""
    from rcmplan.job import run_scenario
    from rcmplan.scene.scenario import load_scenario

    t, c = time.perf_counter(), time.process_time()
    result = run_scenario(load_scenario("default").with_plant(plant_name))
    wall, cpu = time.perf_counter() - t, time.process_time() - c
    s = result.summary()
    sim = float(result.log.time[-1]) if len(result.log) else 0.0
    return {
        "status": s["status"].split(":")[0],
        "rcm": s["max_rcm_deviation_m"],
        "tip": s["max_tip_error_m"],
        "iterations": s["iterations"],
        "sim": sim,
        "rtf": sim / wall,
        "rtf_cpu": sim / cpu,
    }


def injection_rows() -> list[Row]:
    try:
        from rcmplan.sim.registry import PLANTS
    except ImportError:
        return []
    robot = Iramis()
    fine = PiezoParameters.from_robot(robot, resolution=1e-12)
    PLANTS["mujoco-1pm"] = ("rcmplan.sim.mujoco.plant", "MujocoPlant", {"piezo": fine})
    rows: list[Row] = []
    for name, label in (("mujoco", "1 nm resolution"), ("mujoco-1pm", "1 pm resolution")):
        r = injection(name)
        rows += [
            (f"injection ({label}): status", r["status"], "", "ok"),
            (f"injection ({label}): max RCM deviation", f"{1e6 * r['rcm']:.3f}", "um", "<= 10"),
            (f"injection ({label}): max tip error", f"{1e6 * r['tip']:.4f}", "um", "<= 10"),
            (f"injection ({label}): control iterations", str(r["iterations"]), "", ""),
            (f"injection ({label}): simulated time", f"{r['sim']:.2f}", "s", ""),
            (f"injection ({label}): real-time factor, wall", f"{r['rtf']:.2f}", "x", ">= 5"),
            (f"injection ({label}): real-time factor, CPU", f"{r['rtf_cpu']:.2f}", "x", ">= 5"),
        ]
    return rows


def main() -> None:
    robot = Iramis()
    dyn = MujocoPlant(robot, mode="dynamic")
    kin = MujocoPlant(robot, mode="kinematic")
    steps = physics_steps_per_second(dyn)
    rtf = plant_real_time_factor(dyn)
    rtf_cpu = plant_real_time_factor(dyn, clock=time.process_time)
    kp, ka, kg = agreement(kin, 500)
    dp, da, dg = agreement(dyn, 50, settle=0.3)
    rows: list[Row] = [
        ("physics steps per second (dt 1e-4 s)", f"{steps:.0f}", "1/s", ""),
        ("physics alone, real-time factor", f"{steps * dyn.model.opt.timestep:.2f}", "x", ""),
        ("plant advance at 1 kHz, real-time factor, wall", f"{rtf:.2f}", "x", ">= 5"),
        ("plant advance at 1 kHz, real-time factor, CPU", f"{rtf_cpu:.2f}", "x", ">= 5"),
        ("kinematic mode, 500 settings: max tip error", f"{1e6 * kp:.2e}", "um", "<= 1"),
        ("kinematic mode, 500 settings: max tip angle error", f"{1e6 * ka:.2e}", "urad", "<= 1"),
        ("kinematic mode, 500 settings: max loop gap", f"{1e6 * kg:.2e}", "um", "< 1"),
        ("dynamic mode, 50 settled moves: max tip error", f"{1e6 * dp:.2e}", "um", "<= 1"),
        ("dynamic mode, 50 settled moves: max tip angle error", f"{1e6 * da:.2e}", "urad", "<= 1"),
        ("dynamic mode, 50 settled moves: max loop gap", f"{1e6 * dg:.2e}", "um", "< 1"),
    ]
    rows += injection_rows()
    widths = [max(len(r[i]) for r in rows) for i in range(4)]
    head = ("figure", "value", "unit", "target")
    for r in (head, *rows):
        print("  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)))


if __name__ == "__main__":
    main()
