"""`rcmplan robot`: print the robot model as readable tables."""

from __future__ import annotations

import argparse
import math
from dataclasses import asdict
from typing import Any

import numpy as np

from rcmplan.cli.common import add_robot, announce_robot
from rcmplan.cli.output import print_json, table
from rcmplan.robot.iramis import JOINT_NAMES, SLIDER_NAMES, Iramis
from rcmplan.robot.model import RobotModel
from rcmplan.robot.registry import DEFAULT_ROBOT, ROBOTS, is_robot_file, make_robot
from rcmplan.robot.robot_file import read_robot_file


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `robot` subcommand."""
    p = sub.add_parser(
        "robot", help="print a robot model: joints, limits, home pose (--list: every robot)",
        description="Print a robot model. iRAM!S: the standard-DH table of thesis Table 2.1, "
        "every assumed parameter with its source, the home pose and the slider ranges; an arm: "
        "its joints from its model file, their limits, the needle and the home pose.",
    )  # fmt: skip
    add_robot(p, DEFAULT_ROBOT)
    p.add_argument("--list", action="store_true", help="name every available robot and stop")
    p.add_argument("--json", action="store_true", help="print the model as JSON (SI units)")
    p.set_defaults(run=run)


def describe(robot: Iramis) -> str:
    """The model as text: DH table, assumptions, home pose, tip and needle axis, slider ranges."""
    out = ["iRAM!S robot (thesis Table 2.1, standard DH: T = Rz(theta) Tz(d) Tx(a) Rx(alpha))", ""]
    rows = []
    for i, lk in enumerate(robot.dh_links()):
        var = JOINT_NAMES[i]
        theta = f"{lk.theta:+.4f}" + (f" + {var}" if lk.joint == "revolute" else "")
        d = f"{1e3 * lk.d:+.1f} mm" + (f" + {var}" if lk.joint == "prismatic" else "")
        rows.append([str(i + 1), lk.joint, theta, d, f"{1e3 * lk.a:.1f} mm", f"{lk.alpha:+.4f}"])
    out += [table(["link", "joint", "theta [rad]", "d", "a", "alpha [rad]"], rows), ""]
    out += [
        table(
            ["parameter", "value", "unit", "source"],
            [[a.name, a.value, a.unit, a.source] for a in robot.assumptions()],
        ),
        "",
    ]
    q = robot.home
    tip, axis = robot.tip(q), robot.needle_axis(q)
    out.append("home pose: q = (" + ", ".join(f"{v:g}" for v in q) + "), s = 0")
    out.append("tip at home [mm]: (" + ", ".join(f"{1e3 * v:.3f}" for v in tip) + ")")
    out.append("needle axis at home: (" + ", ".join(f"{v:+.4f}" for v in axis) + ")")
    out.append(f"singularity measure at home: {robot.singularity_measure(q):.3f}")
    out.append("")
    rows = []
    for i, name in enumerate(SLIDER_NAMES):
        unit, k = ("rad", 1.0) if name == "q5" else ("mm", 1e3)
        lo, hi, v = robot.lower[i] * k, robot.upper[i] * k, robot.speed[i] * k
        rows.append([name, f"{lo:g}", f"{hi:g}", f"{v:g}", unit])
    out.append(table(["slider", "lower", "upper", "speed /s", "unit"], rows))
    qmax = math.degrees(math.atan((robot.upper[1] - robot.lower[0]) / robot.params.pcjm_spacing))
    out.append(f"largest PCJM angle within travel: {qmax:.1f} deg")
    return "\n".join(out)


def model_dict(robot: Iramis) -> dict[str, Any]:
    """The model as JSON-ready data, SI units named in the keys."""
    links = [
        {"link": i + 1, "joint": lk.joint, "variable": JOINT_NAMES[i], "theta_rad": lk.theta,
         "d_m": lk.d, "a_m": lk.a, "alpha_rad": lk.alpha}
        for i, lk in enumerate(robot.dh_links())
    ]  # fmt: skip
    sliders = [_slider(robot, i, n) for i, n in enumerate(SLIDER_NAMES)]
    q = robot.home
    return {
        "dh_links": links,
        "assumptions": [asdict(a) for a in robot.assumptions()],
        "home_joints": q.tolist(),
        "home_tip_m": robot.tip(q).tolist(),
        "home_needle_axis": robot.needle_axis(q).tolist(),
        "home_singularity_measure": float(robot.singularity_measure(q)),
        "sliders": sliders,
        "units": {"home_joints": "m for q0, q2, q4; rad for q1, q3, q5",
                  "home_needle_axis": "unit vector, base frame",
                  "home_singularity_measure": "min(|cos q1|, |cos q3|), dimensionless"},
    }  # fmt: skip


def _slider(robot: Iramis, i: int, name: str) -> dict[str, Any]:
    unit = "rad" if name == "q5" else "m"
    return {"slider": name, f"lower_{unit}": float(robot.lower[i]),
            f"upper_{unit}": float(robot.upper[i]),
            f"speed_{unit}_per_s": float(robot.speed[i])}  # fmt: skip


def describe_arm(robot: RobotModel, description: str | None = None) -> str:
    """Any robot model as text: joints with limits and speeds, needle, home pose (the
    description defaults to the registered robot's of that name)."""
    rows = []
    for i, name in enumerate(robot.actuator_names):
        unit = robot.actuator_units[i]
        held = "" if i in robot.active else " (needle roll, held)"
        rows.append([name + held, f"{robot.lower[i]:.4g}", f"{robot.upper[i]:.4g}",
                     f"{robot.speed[i]:.4g}", unit])  # fmt: skip
    q = robot.home
    about = ROBOTS.get(robot.name, "") if description is None else description
    return "\n".join([
        f"{robot.name}: {about}" if about else robot.name, "",
        table(["joint", "lower", "upper", "speed /s", "unit"], rows), "",
        f"needle length: {1e3 * robot.needle_length:g} mm",
        "home pose: q = (" + ", ".join(f"{v:.4g}" for v in q) + ")",
        "tip at home [mm]: (" + ", ".join(f"{1e3 * v:.3f}" for v in robot.tip(q)) + ")",
        "needle axis at home: (" + ", ".join(f"{v:+.4f}" for v in robot.needle_axis(q)) + ")",
        f"singularity measure at home: {robot.singularity_measure(q):.3f} "
        f"(threshold {robot.singular_threshold:g})",
    ])  # fmt: skip


def arm_dict(robot: RobotModel) -> dict[str, Any]:
    """Any robot model as JSON-ready data, SI units named in the keys."""
    q = robot.home
    joints = [{"joint": n, "unit": u, "lower": float(robot.lower[i]),
               "upper": float(robot.upper[i]), "speed_per_s": float(robot.speed[i]),
               "moved_by_controller": i in robot.active}
              for i, (n, u) in enumerate(zip(robot.actuator_names, robot.actuator_units,
                                             strict=True))]  # fmt: skip
    return {"robot": robot.name, "joints": joints, "needle_length_m": robot.needle_length,
            "home_joints": q.tolist(), "home_tip_m": robot.tip(q).tolist(),
            "home_needle_axis": robot.needle_axis(q).tolist(),
            "home_singularity_measure": float(robot.singularity_measure(q))}  # fmt: skip


def run(args: argparse.Namespace) -> int:
    """Print the model (as JSON with --json), or the robots with --list."""
    if args.list:
        if args.json:
            print_json({"robots": [{"name": n, "description": d} for n, d in ROBOTS.items()]})
        else:
            print(table(["robot", "description"], [[n, d] for n, d in ROBOTS.items()]))
        return 0
    announce_robot(args.robot, "robot")
    robot = make_robot(args.robot)
    text = None
    if is_robot_file(args.robot):  # its description, and where it was read from
        spec = read_robot_file(args.robot)
        text = f"{spec.description} ({spec.path})" if spec.description else f"from {spec.path}"
    if args.json:
        print_json(model_dict(robot) if isinstance(robot, Iramis) else arm_dict(robot))
        return 0
    np.set_printoptions(suppress=True)
    print(describe(robot) if isinstance(robot, Iramis) else describe_arm(robot, text))
    return 0
