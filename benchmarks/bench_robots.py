"""The default injection on every shipped robot: RCM deviation, tip error, iterations, time.

`python benchmarks/bench_robots.py [--mujoco]`: each robot (iRAM!S, UR5, Panda) with each method
on the kinematic plant (its own scenario: `default`, `ur5`, `panda`); with --mujoco also the
dynamic MuJoCo plant (pinv). The issue's floors: RCM <= 1 um inside the eye and tip error
<= 1 um at the targets on the kinematic plant, RCM <= 10 um on the dynamic MuJoCo plant.
"""

from __future__ import annotations

import sys
from typing import Any

from _common import row
from rcmplan.job import run_scenario
from rcmplan.scene.scenario import load_scenario

SCENARIOS = {"iramis": "default", "ur5": "ur5", "panda": "panda"}
METHODS = ("pinv", "dls", "qp")
UM = 1e6


def injection(robot: str, method: str, plant: str = "kinematic") -> list[dict[str, Any]]:
    """Rows of one run: status, max RCM deviation, max tip error, iterations, wall time."""
    scenario = load_scenario(SCENARIOS[robot]).with_method(method).with_plant(plant)
    result = run_scenario(scenario)
    s = result.summary()
    tag = f"{robot} {method} {plant}"
    rcm, tip = s["max_rcm_deviation_m"], s["max_tip_error_m"]
    floor = "<= 10 um" if plant == "mujoco" else "<= 1 um"
    status = str(s["status"]).split(":")[0]
    return [
        row(f"{tag}: status", status, ""),
        row(
            f"{tag}: max RCM deviation inside the eye",
            UM * rcm if rcm is not None else "-",
            "um",
            target=floor,
        ),
        row(
            f"{tag}: max tip error at the targets",
            UM * tip if tip is not None else "-",
            "um",
            target="<= 1 um" if plant == "kinematic" else "",
        ),
        row(
            f"{tag}: iterations; control wall time",
            f"{s['iterations']}; {s['wall_time_s']:.2f} s",
            "",
        ),
    ]


def rows(mujoco: bool = False) -> list[dict[str, Any]]:
    """Every robot and method on the kinematic plant (and pinv on MuJoCo with `mujoco`)."""
    out: list[dict[str, Any]] = []
    for robot in SCENARIOS:
        for method in METHODS:
            out += injection(robot, method)
    if mujoco:
        for robot in ("ur5", "panda"):
            out += injection(robot, "pinv", "mujoco")
    return out


if __name__ == "__main__":
    from run import print_table

    print_table(rows(mujoco="--mujoco" in sys.argv))
