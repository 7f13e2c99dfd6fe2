"""`rcmplan render`: PNG snapshots of the MuJoCo scene and an animation with the tip trace.

The animation replays the default injection (run on the kinematic plant unless --plant says
otherwise) in the MuJoCo scene with the scenario's eye; `--demo` animates a short generated
slider trajectory instead.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.robot.iramis import Iramis
from rcmplan.sim.mujoco.scene import EyePhantom, phantom_of
from rcmplan.sim.registry import PLANTS


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `render` subcommand."""
    p = sub.add_parser(
        "render", help="render the MuJoCo scene: snapshots and an animation",
        description="Render headless MuJoCo snapshots of the robot and the eye from both "
        "cameras, and an animation of the scenario's run (or --demo) with the tip trace.",
    )  # fmt: skip
    p.add_argument("--out", default="rcmplan-out/render", help="output folder")
    p.add_argument("--width", type=int, default=640, help="image width in pixels (640)")
    p.add_argument("--height", type=int, default=480, help="image height in pixels (480)")
    p.add_argument("--camera", choices=("closeup", "overview"), default="closeup",
                   help="animation camera (closeup)")  # fmt: skip
    p.add_argument("--frames", type=int, default=60, help="animation frames (60)")
    p.add_argument("--fps", type=float, default=20.0, help="animation frame rate (20)")
    p.add_argument(
        "--format", choices=("gif", "mp4"), default="gif", help="animation (mp4: `video` extra)"
    )
    p.add_argument("--scenario", default="default", help="scenario to animate (default)")
    p.add_argument("--plant", choices=sorted(PLANTS), default="kinematic",
                   help="plant the scenario runs on (kinematic)")  # fmt: skip
    p.add_argument("--demo", action="store_true", help="animate a generated slider trajectory")
    p.set_defaults(run=run)


def demo_trajectory(robot: Iramis, n: int = 240) -> FloatArray:
    """Sliders (n, 6): insert the needle 10 mm, then tilt it with both PCJMs and come back."""
    t = 0.5 - 0.5 * np.cos(np.linspace(0.0, 2.0 * np.pi, n))[:, None]  # 0 -> 1 -> 0
    insert = np.clip(2.0 * t, 0.0, 1.0) * np.array([0.0, 0.0, 0.0, 0.0, 10e-3, 0.0])
    tilt = np.clip(2.0 * t - 1.0, 0.0, 1.0) * np.array([1e-3, -1e-3, -1e-3, 1e-3, 0.0, 0.0])
    return robot.home_actuators + insert + tilt


def scenario_trajectory(
    args: argparse.Namespace, robot: Iramis
) -> tuple[FloatArray, EyePhantom, tuple[float, float] | None]:
    """Run the scenario; its logged sliders, the eye as a scene phantom and the needle's arc."""
    from rcmplan.job import run_scenario
    from rcmplan.scene.scenario import load_scenario

    scenario = load_scenario(args.scenario).with_plant(args.plant)
    result = run_scenario(scenario)
    if not result.ok:
        print(f"rcmplan render: run stopped early ({result.message}); animating the partial log")
    eye = scenario.eye(robot)
    phantom = phantom_of(eye, scenario.points(eye))
    sliders = np.vstack([robot.home_actuators, result.log.sliders])
    return sliders, phantom, scenario.needle.arc()


def run(args: argparse.Namespace) -> int:
    """Write home snapshots from both cameras and the animation; print the paths."""
    from rcmplan.sim.mujoco.plant import MujocoPlant
    from rcmplan.sim.mujoco.render import SceneRenderer, animate, save_animation, save_png

    robot = Iramis()
    out = Path(args.out)
    if args.demo:
        sliders, eye, name, arc = demo_trajectory(robot), None, "demo", None
    else:
        sliders, phantom, arc = scenario_trajectory(args, robot)
        eye, name = phantom, args.scenario
    plant = MujocoPlant(robot, mode="kinematic", eye=eye, needle_arc=arc)
    renderer = SceneRenderer(plant.scene()[0], args.width, args.height)
    written = [
        save_png(out / f"home_{cam}.png", renderer.render(plant.scene()[1], cam))
        for cam in ("overview", "closeup")
    ]
    frames = animate(plant, sliders, renderer, args.camera, args.frames)
    written.append(save_animation(out / f"{name}.{args.format}", frames, args.fps))
    written.append(save_png(out / f"{name}_end_{args.camera}.png", frames[-1]))
    renderer.close()
    for path in written:
        print(path, file=sys.stdout)
    return 0
