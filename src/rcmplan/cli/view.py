"""`rcmplan view`: a run in 3D in the browser, or the needle driven live.

`rcmplan view RUN_DIR` replays a run folder (inject, spiral, teleop, a subretinal episode with
its B-scans) or a comparison folder (compare); `rcmplan view --live` serves a draggable target
that the robot's needle tip follows in real time with the RCM held; one of the two is needed.
The folder is read and checked before the server starts; the address is printed on one line;
Ctrl-C (or SIGTERM) stops the server cleanly (exit 0).
"""

from __future__ import annotations

import argparse
import sys
import threading
from typing import Any

from rcmplan.cli import interrupts
from rcmplan.cli.common import add_plant, add_robot, add_scenario, announce_robot
from rcmplan.cli.teleop import FILTERS  # not rcmplan.teleop: its import costs scipy.signal


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `view` subcommand."""
    p = sub.add_parser(
        "view", help="a run in 3D in the browser (or --live: drive the needle)",
        description="Serve a 3D view of a run folder in the browser (robot, needle, eye, "
        "trocar, targets, tip trace by RCM deviation; a timeline and panels), or with --live a "
        "draggable target the needle tip follows in real time with the RCM held.",
    )  # fmt: skip
    what = p.add_mutually_exclusive_group(required=True)
    what.add_argument("run_dir", nargs="?", metavar="RUN_DIR",
                      help="a run folder (inject, spiral, teleop, a subretinal episode) or a "
                      "compare folder")  # fmt: skip
    what.add_argument("--live", action="store_true", help="drive the needle live instead")
    p.add_argument("--port", type=int, default=8080, help="port to serve on (8080; 0: any)")
    p.add_argument("--host", default="127.0.0.1", help="address to serve on (127.0.0.1)")
    p.add_argument("--no-browser", action="store_true", help="do not open a browser")
    live = p.add_argument_group("live mode")
    add_scenario(live, "default", "scenario of the robot, the eye and the start point p3")
    add_robot(live)
    add_plant(live, default="kinematic")
    live.add_argument("--scale", type=float, default=1.0,
                      help="motion scaling in [1, 50]: the tip moves 1/scale of the "
                      "gizmo (1)")  # fmt: skip
    live.add_argument("--filter", choices=FILTERS, default="none",
                      help="tremor filter on the gizmo's motion (none)")  # fmt: skip
    live.add_argument("--no-realtime", action="store_true",
                      help="keep the control thread at normal scheduling (default: real-time "
                      "where the system grants it)")  # fmt: skip
    p.set_defaults(run=run)


def build(args: argparse.Namespace, server: Any, source: Any) -> tuple[Any, str]:
    """The view of `source` (live settings, or the runs of RUN_DIR) and what it shows."""
    if args.live:
        from rcmplan.view.live import LiveView

        return LiveView(server, source), f"live control of {source.robot.name}"
    from rcmplan.view.replay import ReplayView

    return ReplayView(server, source), f"{args.run_dir}"


def checked_source(args: argparse.Namespace) -> Any:
    """What the view will show, read and checked before any server starts: the live settings,
    or the runs of RUN_DIR."""
    if args.live:
        from rcmplan._validate import scalar
        from rcmplan.teleop.scaling import SCALE_RANGE
        from rcmplan.view.live import live_settings

        scale = scalar("--scale", args.scale, *SCALE_RANGE)
        settings = live_settings(args.scenario, args.robot, args.plant, not args.no_realtime,
                                 scale, args.filter)  # fmt: skip
        announce_robot(settings.teleop.robot, "view")
        return settings
    from rcmplan.view.run_folder import load_runs

    return load_runs(args.run_dir)


def run(args: argparse.Namespace) -> int:
    """Serve until Ctrl-C or SIGTERM; errors in the folder or the port before any server."""
    from rcmplan.view.server import address, open_browser, serve, start_server, stop_server

    source = checked_source(args)
    server = start_server(args.host, args.port)
    view = None
    try:
        view, what = build(args, server, source)
        url = address(server, args.host)
        print(f"rcmplan view: {what} at {url} (Ctrl-C stops)", flush=True)
        if not args.no_browser:
            open_browser(url)
        serve(threading.Event())
    except KeyboardInterrupt as exc:
        with interrupts.shielded():
            print(f"rcmplan view: stopped by {interrupts.signal_name(exc)}", file=sys.stderr)
        return 0
    finally:
        with interrupts.shielded():
            if view is not None:
                view.close()
            stop_server(server)
    return 0
