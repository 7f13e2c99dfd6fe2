"""Every control method on the dynamic MuJoCo plant: the default injection, now and before.

Run alone: MUJOCO_GL=egl python benchmarks/bench_mujoco_methods.py [--method qp ...]
For pinv, DLS and the QP: status, max RCM deviation inside the eye, max tip error at the
targets, wall time, simulated time and real-time factor (over wall and over CPU time: the host
is shared) of `rcmplan inject --plant mujoco`
(`run_scenario`, on its default execution path: every method compiled). Peer
of each: the same method on the plant with the former velocity-step servo reference
(`PiezoParameters.ramp_time = 0`), run beside it; and MuJoCo's bare step rate measured before
each run, since this host's speed drifts by up to 2x within a minute. The issue's targets:
every method ok, RCM <= 2 um, tip error <= 2 um, the QP's real-time factor >= 2.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import mujoco

from _common import row
from rcmplan import Iramis
from rcmplan.job import run_scenario
from rcmplan.scene.scenario import load_scenario
from rcmplan.sim.mujoco import actuators
from rcmplan.sim.mujoco.plant import MujocoPlant

METHODS = ("pinv", "dls", "qp")
UM = 1e6


def bare_real_time_factor(n: int = 10000) -> float:
    """MuJoCo's own physics of the iRAM!S model, simulated over wall time (no control)."""
    plant = MujocoPlant(Iramis())
    t = time.perf_counter()
    mujoco.mj_step(plant.model, plant.data, nstep=n)
    return n * plant.model.opt.timestep / (time.perf_counter() - t)


@contextmanager
def ramp(seconds: float | None) -> Iterator[None]:
    """Plants built inside get this `ramp_time` (None: the default)."""
    original = actuators.PiezoParameters.from_robot
    if seconds is not None:

        def patched(cls: Any, robot: Any, **kw: Any) -> Any:
            return original(robot, **{**kw, "ramp_time": seconds})

        actuators.PiezoParameters.from_robot = classmethod(patched)  # type: ignore[assignment]
    try:
        yield
    finally:
        actuators.PiezoParameters.from_robot = original  # type: ignore[method-assign]


def injection(method: str, ramp_time: float | None = None) -> dict[str, Any]:
    """One dynamic default injection; its summary figures and MuJoCo's bare rate before it."""
    bare = bare_real_time_factor()
    with ramp(ramp_time):
        cpu = time.process_time()
        result = run_scenario(load_scenario("default").with_plant("mujoco").with_method(method))
        cpu = time.process_time() - cpu
    s = result.summary()
    sim = float(result.log.time[-1]) if len(result.log) else 0.0
    wall = s["wall_time_s"]
    return {"status": s["status"], "message": s["message"], "rcm": s["max_rcm_deviation_m"],
            "tip": s["max_tip_error_m"], "iterations": s["iterations"], "wall": wall, "sim": sim,
            "rtf": sim / wall, "rtf_cpu": sim / cpu, "bare": bare}  # fmt: skip


def um(value: float | None) -> float | str:
    return UM * value if value is not None else "-"


def method_rows(method: str) -> list[dict[str, Any]]:
    """The rows of one method: now (ramped reference) beside before (velocity steps)."""
    run_scenario(load_scenario("default").with_plant("mujoco").with_method(method))  # warm-up
    now, before = injection(method), injection(method, ramp_time=0.0)
    tag = f"{method}, dynamic default injection"
    peer = "velocity-step reference (ramp 0), same run"
    return [
        row(f"{tag}: status", now["status"], "", peer, None, "ok"),
        row(f"{tag}: status, velocity-step reference", before["status"], ""),
        row(f"{tag}: max RCM deviation", um(now["rcm"]), "um", peer, um(before["rcm"]),  # type: ignore[arg-type]
            "<= 2 um"),
        row(f"{tag}: max tip error at the targets", um(now["tip"]), "um", peer,
            um(before["tip"]), "<= 2 um"),  # type: ignore[arg-type]
        row(f"{tag}: iterations; simulated time", f"{now['iterations']}; {now['sim']:.2f} s",
            "", peer, None),
        row(f"{tag}: wall time", now["wall"], "s", peer, before["wall"]),
        row(f"{tag}: real-time factor", now["rtf"], "x", "MuJoCo physics alone, before the run",
            now["bare"], ">= 2" if method == "qp" else ""),
        row(f"{tag}: real-time factor over CPU time", now["rtf_cpu"], "x", peer,
            before["rtf_cpu"], ">= 2" if method == "qp" else ""),
    ]  # fmt: skip


def rows(methods: tuple[str, ...] = METHODS) -> list[dict[str, Any]]:
    """Every method's rows."""
    return [r for m in methods for r in method_rows(m)]


if __name__ == "__main__":
    from run import print_table

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--method", action="append", choices=METHODS, help="repeatable")
    args = parser.parse_args()
    print_table(rows(tuple(args.method or METHODS)))
