"""`rcmplan render`: PNG snapshots of the MuJoCo scene and an animation with the tip trace.

The animation replays the scenario's run (the default injection on the kinematic plant unless
--scenario, --robot, --method or --plant say otherwise) in the MuJoCo scene with the scenario's
eye; `--demo` animates a short generated actuator trajectory instead. iRAM!S is drawn from its
MuJoCo model's own geometry, an arm's links as capsules between its joints (`arm_model`'s
scenery); either draws a curved needle's arc after its shaft.

Outputs in --out: summary.json (the run's summary with the images under `figures`; a demo's
names the images alone), the run's log (log.npz, log.csv) and the images in figures/.
"""

from __future__ import annotations

import argparse
import re
import sys
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rcmplan._validate import FloatArray, integer, scalar
from rcmplan.cli import interrupts
from rcmplan.cli.common import (
    add_json,
    add_method,
    add_out,
    add_plant,
    add_robot,
    add_scenario,
    scenario_from_args,
)
from rcmplan.exceptions import RcmplanError, require_extra
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel
from rcmplan.robot.registry import make_robot
from rcmplan.sim.mujoco.scene import OFFSCREEN

if TYPE_CHECKING:
    from rcmplan.analysis.result import RunResult

CAMERAS = ("closeup", "overview")
MAX_FRAMES = 10_000
MAX_FPS = 100.0  # GIF frame times are whole hundredths of a second
MIN_SIZE = 16  # pixels


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `render` subcommand."""
    p = sub.add_parser(
        "render", help="render the MuJoCo scene: snapshots and an animation",
        description="Render headless MuJoCo snapshots of the robot and the eye from both "
        "cameras, and an animation of the scenario's run (or --demo) with the tip trace.",
    )  # fmt: skip
    add_scenario(p, "default", "scenario to run and animate")
    add_robot(p)
    add_method(p)
    add_plant(p, default="kinematic")
    p.add_argument("--demo", action="store_true", help="animate a generated actuator trajectory")
    p.add_argument("--width", type=int, default=640,
                   help=f"image width in pixels, {MIN_SIZE}-{OFFSCREEN[0]} (640)")  # fmt: skip
    p.add_argument("--height", type=int, default=480,
                   help=f"image height in pixels, {MIN_SIZE}-{OFFSCREEN[1]} (480)")  # fmt: skip
    p.add_argument("--camera", choices=CAMERAS, default="closeup",
                   help="animation camera (closeup)")  # fmt: skip
    p.add_argument("--frames", type=int, default=60, help=f"animation frames, 1-{MAX_FRAMES} (60)")
    p.add_argument("--fps", type=float, default=20.0,
                   help=f"animation frame rate, above 0 to {MAX_FPS:g} (20)")  # fmt: skip
    p.add_argument(
        "--format", choices=("gif", "mp4"), default="gif", help="animation (mp4: `video` extra)"
    )
    add_out(p, "render")
    add_json(p)
    p.set_defaults(run=run)


def demo_trajectory(robot: RobotModel, n: int = 240) -> FloatArray:
    """Actuators (n, robot's count). iRAM!S: insert the needle 10 mm, then tilt it with both
    PCJMs and come back; an arm: turn each moving joint by up to 0.2 rad (alternate signs,
    within a tenth of its travel of its limits) and come back."""
    t = 0.5 - 0.5 * np.cos(np.linspace(0.0, 2.0 * np.pi, n))[:, None]  # 0 -> 1 -> 0
    if isinstance(robot, Iramis):
        insert = np.clip(2.0 * t, 0.0, 1.0) * np.array([0.0, 0.0, 0.0, 0.0, 10e-3, 0.0])
        tilt = np.clip(2.0 * t - 1.0, 0.0, 1.0) * np.array([1e-3, -1e-3, -1e-3, 1e-3, 0.0, 0.0])
        return robot.home_actuators + insert + tilt
    home = robot.home_actuators
    turn = np.zeros_like(home)
    for k, j in enumerate(robot.active):
        turn[j] = 0.2 if k % 2 == 0 else -0.2
    margin = 0.1 * (robot.upper - robot.lower)
    return np.clip(home + t * turn, robot.lower + margin, robot.upper - margin)


def run_scenario_of(args: argparse.Namespace) -> RunResult:
    """The scenario's run (--scenario, --robot, --method, --plant), nothing written yet."""
    from rcmplan.job import run_scenario

    return replace(run_scenario(scenario_from_args(args)), command="render")


def run(args: argparse.Namespace) -> int:
    """Write home snapshots from both cameras, the animation and its last frame in
    OUT/figures, and summary.json naming them; print it (--json) or the paths. Refused (a bad
    option), it writes summary.json with the error and re-raises (exit 2). Interrupted during
    the run, it writes the records so far; afterwards, the run's summary and log with status
    `interrupted`, naming no image."""
    from rcmplan.analysis.report import prepare_folder
    from rcmplan.cli.output import interrupted_message, write_stopped

    out = prepare_folder(args.out)
    try:
        with interrupts.surfaced():  # an interrupt numba or a C callback wrapped, as itself
            size = image_size(args)
            frames = integer("--frames", args.frames, 1, MAX_FRAMES)
            fps = scalar("--fps", args.fps, 0.0, MAX_FPS, low_open=True)
            if args.format == "mp4":
                require_extra("imageio_ffmpeg", "video")
            result = None if args.demo else run_scenario_of(args)
    except RcmplanError as exc:
        write_stopped(out, args, exc.status, f"{type(exc).__name__}: {exc}")
        raise
    except KeyboardInterrupt as exc:  # the run's records so far, if it began
        partial = getattr(exc, "result", None)
        if partial is not None:
            write_stopped(out, args, "interrupted", interrupted_message(exc, "during the run"),
                          replace(partial, command="render"))  # fmt: skip
        raise
    name = "demo" if result is None else re.sub(r"[^\w.-]", "_", result.scenario.name)
    try:
        with interrupts.surfaced():
            robot, eye, actuators = motion(args, result, out)
            arc = None if result is None else result.scenario.needle.arc()
            plant = scene_plant(robot, eye, arc)
            figures = render_figures(args, plant, actuators, out / "figures", name, size,
                                     frames, fps)  # fmt: skip
    except RcmplanError as exc:
        write_render_summary(out, result, {}, (exc.status, f"{type(exc).__name__}: {exc}"))
        raise
    except KeyboardInterrupt as exc:  # the run's summary and log, and no image named
        ended = "" if result is None else f" (the run ended with status {result.status!r})"
        write_stopped(out, args, "interrupted",
                      interrupted_message(exc, f"while rendering{ended}"), result)  # fmt: skip
        raise
    doc = write_render_summary(out, result, figures)
    interrupts.finished()
    if args.json:
        from rcmplan.cli.output import print_json

        print_json(doc)
    else:
        for path in figures.values():
            print(path)
    return 0


def motion(
    args: argparse.Namespace, result: RunResult | None, out: Path
) -> tuple[RobotModel, Any, FloatArray]:
    """(the model the scene draws, the eye phantom or None, the actuators to animate): the
    run's (its log and summary written, how it ended said on stderr; a curved needle's shaft
    drawn with its arc), or the demo's trajectory on --robot (iRAM!S by default)."""
    from rcmplan.analysis.report import write_summary
    from rcmplan.job import plant_model
    from rcmplan.sim.mujoco.scene import phantom_of

    if result is None:
        for stale in ("log.npz", "log.csv"):  # an earlier run's log: not this render's
            (out / stale).unlink(missing_ok=True)
        robot = make_robot(args.robot or "iramis")
        return robot, None, demo_trajectory(robot)
    write_summary(result, out)
    if not result.finished:
        print(f"rcmplan render: run stopped early ({result.message}); animating the partial "
              "log", file=sys.stderr)  # fmt: skip
    elif not result.ok:
        print(f"rcmplan render: {result.status}: {result.message}", file=sys.stderr)
    robot = plant_model(result.robot)
    eye = result.scenario.eye(result.robot)
    phantom = phantom_of(eye, result.scenario.points(eye))
    return robot, phantom, np.vstack([robot.home_actuators, result.log.sliders])


def scene_plant(robot: RobotModel, eye: Any, arc: Any) -> Any:
    """The kinematic MuJoCo plant that replays the motion (`make_plant`: iRAM!S's or an arm's),
    its scene with a curved needle's arc (R [m], alpha [rad]) when given; eye None: the
    robot's default eye."""
    from rcmplan.sim.registry import make_plant

    return make_plant("mujoco-kinematic", robot, {"eye": eye, "needle_arc": arc})


def image_size(args: argparse.Namespace) -> tuple[int, int]:
    """(width, height) of --width and --height, checked against what the scene renders."""
    return (integer("--width", args.width, MIN_SIZE, OFFSCREEN[0]),
            integer("--height", args.height, MIN_SIZE, OFFSCREEN[1]))  # fmt: skip


def render_figures(args: argparse.Namespace, plant: Any, actuators: FloatArray, folder: Path,
                   name: str, size: tuple[int, int], frames: int,
                   fps: float) -> dict[str, Path]:  # fmt: skip
    """The home snapshots from both cameras, the animation and its last frame."""
    from rcmplan.sim.mujoco.render import SceneRenderer, animate, save_animation, save_png

    model, data = plant.scene()
    renderer = SceneRenderer(model, *size)
    try:
        made = {f"home_{cam}": save_png(folder / f"home_{cam}.png", renderer.render(data, cam))
                for cam in ("overview", "closeup")}  # fmt: skip
        images = animate(plant, actuators, renderer, args.camera, frames)
        made["animation"] = save_animation(folder / f"{name}.{args.format}", images, fps)
        made["last_frame"] = save_png(folder / f"{name}_end_{args.camera}.png", images[-1])
    finally:
        renderer.close()
    return made


def write_render_summary(
    out: Path, result: Any, figures: dict[str, Path], stopped: tuple[str, str] | None = None
) -> dict[str, Any]:
    """summary.json: the run's (written with its log) with the images under `figures`, or a
    demo's naming the images alone; `stopped`: the (status, message) of a render that stopped
    (an error, an interrupt), its images not named."""
    from rcmplan.analysis.report import summary_json, write_json

    if result is None:
        doc: dict[str, Any] = {"command": "render", "procedure": "demo", "status": "ok",
                               "message": ""}  # fmt: skip
    else:
        doc = summary_json(result)
    doc["figures"] = {key: str(path) for key, path in figures.items()}
    if stopped is not None:
        doc.update(status=stopped[0], message=stopped[1])
    write_json(out / "summary.json", doc)
    return doc
