"""MuJoCo plant figures: physics speed, real-time factor, kinematic agreement, the injection.

Run alone: MUJOCO_GL=egl python benchmarks/bench_mujoco.py
Only the real-time factor, N runs spread over time: python benchmarks/bench_mujoco.py --watch N
Rows follow benchmarks/README.md. Speeds of the plant alone are medians of three runs.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np

from _common import quick, row, use_path
from rcmplan import Iramis
from rcmplan.sim.mujoco.plant import MujocoPlant

SEED = 20180507


def median_of_three(fn: Callable[[], float]) -> float:
    return statistics.median(fn() for _ in range(3))


def physics_steps_per_second(plant: MujocoPlant, n: int = 20000) -> float:
    def once() -> float:
        t = time.perf_counter()
        mujoco.mj_step(plant.model, plant.data, nstep=n)
        return n / (time.perf_counter() - t)

    plant.reset(plant.robot.home_actuators)
    return median_of_three(once)


def plant_real_time_factor(
    plant: MujocoPlant, seconds: float = 2.0, clock: Callable[[], float] = time.perf_counter
) -> float:
    """Simulated over elapsed time (wall or CPU `clock`) for `advance` with a new random
    command every 10 ms."""
    robot, rng = plant.robot, np.random.default_rng(SEED)

    def once() -> float:
        plant.reset(robot.home_actuators)
        t = clock()
        for k in range(round(seconds / plant.dt)):
            if k % 10 == 0:
                plant.command_actuators(rng.uniform(0.5 * robot.lower, 0.5 * robot.upper))
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
            plant.command_actuators(s)
            plant.settle(settle)
        else:
            plant.reset(s)
        T = robot.forward_kinematics(robot.joints_from_actuators(plant.read_actuators()))
        Ts = plant.tip_pose()
        err = (np.linalg.norm(Ts[:3, 3] - T[:3, 3]), angle(Ts[:3, :3], T[:3, :3]), plant.loop_gap())
        worst = np.maximum(worst, err)
    return float(worst[0]), float(worst[1]), float(worst[2])


def injection(path: str) -> dict[str, Any]:
    """The default injection on the dynamic MuJoCo plant via rcmplan.job.run_scenario.

    path: "closed" (the whole loop compiled, MuJoCo called from it), "per-iteration" (compiled
    control, the plant stepped from Python) or "reference" (Python control and plant)."""
    from rcmplan.job import run_scenario
    from rcmplan.scene.scenario import load_scenario

    use_path("off" if path == "reference" else "on")
    init = MujocoPlant.__init__

    def stepped_init(plant: MujocoPlant, *args: Any, **kwargs: Any) -> None:
        init(plant, *args, **kwargs)
        plant.compiled_physics = False  # the plant steps from Python

    if path == "per-iteration":
        MujocoPlant.__init__ = stepped_init  # type: ignore[method-assign]
    try:
        t, c = time.perf_counter(), time.process_time()
        result = run_scenario(load_scenario("default").with_plant("mujoco"))
        wall, cpu = time.perf_counter() - t, time.process_time() - c
    finally:
        use_path(None)
        MujocoPlant.__init__ = init  # type: ignore[method-assign]
    s = result.summary()
    sim = float(result.log.time[-1]) if len(result.log) else 0.0
    return {"status": s["status"].split(":")[0], "rcm": s["max_rcm_deviation_m"],
            "tip": s["max_tip_error_m"], "iterations": s["iterations"], "sim": sim,
            "rtf": sim / wall, "rtf_cpu": sim / cpu}  # fmt: skip


class SiteRecorder(MujocoPlant):
    """The dynamic plant, keeping MuJoCo's needle base and tip sites after every period
    (stepped from Python: it declines the compiled closed loop)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.compiled_physics = False
        self.sites: dict[int, np.ndarray] = {}

    def advance(self) -> None:
        super().advance()
        period = round(self.time / self.dt)
        self.sites[period] = np.concatenate([self.needle_base_position(), self.tip_position()])


def simulated_needle_rcm() -> tuple[float, float]:
    """(max trocar-to-needle-line distance from MuJoCo's sites, the same from the log's FK of
    the read sliders) over the records inside the eye of the dynamic default injection [m]."""
    from rcmplan.control.methods import make_solver
    from rcmplan.controller import Controller
    from rcmplan.scene.scenario import load_scenario

    robot, sc = Iramis(), load_scenario("default")
    eye = sc.eye(robot)
    plant = SiteRecorder(robot, eye=eye, points=sc.points(eye), dt=sc.dt)
    solver = make_solver(sc.method, sc.method_settings, robot, plant, eye=eye, dt=sc.dt)
    log = Controller(plant, solver, settings=sc.loop).run(sc.phases(robot))
    inside = np.flatnonzero(np.all(np.isfinite(log.trocar), axis=1))
    sim = np.array([plant.sites[round(t / plant.dt)] for t in log.time[inside]])
    base, tip, trocar = sim[:, :3], sim[:, 3:], log.trocar[inside]
    u = (tip - base) / np.linalg.norm(tip - base, axis=1, keepdims=True)
    d = trocar - base
    perp = d - np.sum(d * u, axis=1, keepdims=True) * u
    return float(np.linalg.norm(perp, axis=1).max()), float(log.line_distance()[inside].max())


def injection_rows(physics: Callable[[], float]) -> list[dict[str, Any]]:
    """The dynamic default injection on the three paths; the closed compiled loop three times
    (median and slowest), each run next to a measurement of MuJoCo's bare step rate, since
    this host's speed drifts by up to 2x within a minute."""
    from rcmplan.warmup import compile_kernels

    compile_kernels()  # load (or compile) once, outside the timed runs
    closed, rates = [], []
    for _ in range(1 if quick() else 3):
        rates.append(physics())
        closed.append(injection("closed"))
    rates.append(physics())
    per_it, ref = injection("per-iteration"), injection("reference")
    sim_line, fk_line = simulated_needle_rcm()
    fast = sorted(closed, key=lambda r: r["rtf"])[len(closed) // 2]
    slow = min(closed, key=lambda r: r["rtf"])
    bare = statistics.median(rates) * 1e-4  # physics alone, real-time factor
    tag = "dynamic injection (1 nm sliders, 1 kHz control, physics 1e-4 s)"
    return [
        row(f"{tag}: status", fast["status"], "", target="ok"),
        row(f"{tag}: max RCM deviation", 1e6 * fast["rcm"], "um", target="<= 2 um"),
        row(f"{tag}: max tip error", 1e6 * fast["tip"], "um", target="<= 2 um"),
        row(f"{tag}: max trocar distance from MuJoCo's needle (sites)", 1e6 * sim_line, "um",
            "same from FK of the read sliders", 1e6 * fk_line, "<= 2 um"),
        row(f"{tag}: control iterations / simulated time", fast["iterations"], "", "s",
            fast["sim"]),
        row(f"{tag}: real-time factor, compiled closed loop (median of {len(closed)})",
            fast["rtf"], "x", "MuJoCo physics alone, same runs", bare, ">= 5"),
        row(f"{tag}: real-time factor, compiled closed loop (slowest)", slow["rtf"], "x",
            "", None, ">= 5"),
        row(f"{tag}: real-time factor (CPU), compiled closed loop", fast["rtf_cpu"], "x",
            "", None, ">= 5"),
        row(f"{tag}: real-time factor, plant stepped from Python", per_it["rtf"], "x",
            "compiled closed loop", fast["rtf"]),
        row(f"{tag}: real-time factor, reference Python control", ref["rtf"], "x",
            "compiled closed loop", fast["rtf"]),
        row(f"{tag}: MuJoCo bare step rate during these runs (min / max)", min(rates), "1/s",
            "max", max(rates)),
    ]  # fmt: skip


def rows() -> list[dict[str, Any]]:
    """Every MuJoCo figure."""
    robot = Iramis()
    dyn = MujocoPlant(robot, mode="dynamic")
    kin = MujocoPlant(robot, mode="kinematic")
    steps = physics_steps_per_second(dyn)
    kp, ka, kg = agreement(kin, 500)
    dp, da, dg = agreement(dyn, 50, settle=0.3)
    out = [
        row("MuJoCo physics steps per second (dt 1e-4 s)", steps, "1/s"),
        row("MuJoCo physics alone, real-time factor", steps * dyn.model.opt.timestep, "x"),
        row("plant.advance() from Python at 1 kHz, random commands: real-time factor",
            plant_real_time_factor(dyn), "x"),
        row("kinematic mode, 500 settings: max tip error", 1e6 * kp, "um", target="<= 1 um"),
        row("kinematic mode, 500 settings: max tip angle error", 1e6 * ka, "urad",
            target="<= 1 urad"),
        row("kinematic mode, 500 settings: max loop gap", 1e6 * kg, "um", target="< 1 um"),
        row("dynamic mode, 50 settled moves: max tip error", 1e6 * dp, "um", target="<= 1 um"),
        row("dynamic mode, 50 settled moves: max tip angle error", 1e6 * da, "urad",
            target="<= 1 urad"),
        row("dynamic mode, 50 settled moves: max loop gap", 1e6 * dg, "um", target="< 1 um"),
    ]  # fmt: skip
    return out + injection_rows(lambda: physics_steps_per_second(dyn, 10000))


def watch(runs: int, pause: float = 8.0) -> None:
    """Time the compiled closed-loop injection `runs` times, each beside MuJoCo's bare step rate,
    and print one line per run and the range (the host's speed drifts)."""
    from rcmplan.warmup import compile_kernels

    compile_kernels()
    dyn = MujocoPlant(Iramis(), mode="dynamic")
    out = []
    for _ in range(runs):
        bare = physics_steps_per_second(dyn, 10000)
        r = injection("closed")
        out.append((bare, r["rtf"]))
        print(f"{time.strftime('%H:%M:%S')}  bare {bare:9.0f} steps/s  real-time factor "
              f"{r['rtf']:5.2f}  status {r['status']}", flush=True)  # fmt: skip
        time.sleep(pause)
    b, f = np.array(out).T
    print(
        f"{runs} runs: real-time factor {f.min():.2f} to {f.max():.2f} (median "
        f"{np.median(f):.2f}); bare step rate {b.min():.0f} to {b.max():.0f} steps/s"
    )


if __name__ == "__main__":
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--watch", type=int, metavar="N", help="only time N injection runs")
    args = parser.parse_args()
    if args.watch:
        watch(args.watch)
    else:
        from run import print_table

        print_table(rows())
