"""Replay a run in the view: the robot, needle and eye at any record, a timeline over the log,
panels with the phase, time, RCM deviation, tip error and actuators against their travel.

A comparison folder shows each method's run in turn (a `run` menu); the robot and the eye are
the same for all of them. A subretinal episode's folder (with bscans.npz) adds the iOCT B-scan
the controller last received at the replayed time (`bscan_panel`).
"""

from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.control.log import RunLog
from rcmplan.exceptions import InvalidInputError, MissingExtraError, RunFolderError
from rcmplan.robot.model import RobotModel
from rcmplan.view.bscan_panel import bscan_panel
from rcmplan.view.camera import CameraViews
from rcmplan.view.links import robot_links
from rcmplan.view.needle import needle_polyline
from rcmplan.view.panels import ActuatorPanel, StatePanel, length, travel
from rcmplan.view.run_folder import RunData
from rcmplan.view.scene import SceneDrawing
from rcmplan.view.timeline import Timeline
from rcmplan.view.trace import rcm_deviation_norm, trace_of


def run_robot(run: RunData) -> tuple[RobotModel | None, str]:
    """The robot model of a run (a curved needle fitted), or None and why not."""
    from rcmplan.robot.registry import make_robot
    from rcmplan.scene.curved_procedure import NeedleOptions

    try:
        robot = make_robot(run.robot_source)
    except (InvalidInputError, MissingExtraError) as exc:
        return None, f"robot {run.robot_source!r} not modelled here ({exc}): needle and eye only"
    if run.scene.needle_arc is not None:
        radius, angle = run.scene.needle_arc
        robot = NeedleOptions("curved", radius, angle).fit(robot)
    width = run.log.joints.shape[1]
    if width != len(robot.joint_names):
        raise RunFolderError(
            run.folder / "log.npz", f"records {width} joints, but robot {robot.name!r} has "
            f"{len(robot.joint_names)}: a log of another robot or version",
        )  # fmt: skip
    return robot, ""


class RunArrays:
    """What the view reads per record of one run, computed once."""

    def __init__(self, run: RunData) -> None:
        log = run.log
        self.run = run
        self.log: RunLog = log
        self.deviation = rcm_deviation_norm(log)
        self.tip_error = np.linalg.norm(log.tip - log.target_tip, axis=1)
        self.max_deviation = float(np.nanmax(self.deviation)) if np.isfinite(
            self.deviation).any() else 0.0  # fmt: skip
        self.trace = trace_of(log.tip, self.deviation, run.scene.eye_radius)
        self.eye_offset = eye_offsets(log.trocar, run.scene.trocar)


def eye_offsets(trocar: FloatArray, at_start: FloatArray) -> FloatArray:
    """Per record, how far [m] the eye has moved (N, 3): the logged trocar less the scene's,
    where the needle is in the trocar; in free space (trocar NaN) the nearest record's before
    it, else after it; zero if no record has a trocar (the eye does not move in the log)."""
    out = np.zeros(trocar.shape)
    known = np.flatnonzero(np.isfinite(trocar[:, 0]))
    if known.size == 0:
        return out
    before = np.searchsorted(known, np.arange(len(trocar)), side="right") - 1
    nearest = known[np.maximum(before, 0)]  # the last known record, or the first after
    return np.asarray(trocar[nearest] - np.asarray(at_start), dtype=np.float64)


class ReplayView:
    """A run (or a comparison's runs) in a viser server.

    Args:
        server: A running viser server. runs: The runs to show (one, or one per method).
    """

    def __init__(self, server: Any, runs: list[RunData]) -> None:
        self.server = server
        self.runs = [RunArrays(r) for r in runs]
        self.robot, why = run_robot(runs[0])
        self.lock = threading.Lock()
        self.current = self.runs[0]
        self.index = 0
        self.shows = 0
        self.show_time_s = 0.0
        gui = server.gui
        self.links = robot_links(server, self.robot)
        self.notes = [n for n in (why, self.links.note) if n]
        self.drawing = SceneDrawing(server.scene, runs[0].scene)
        self.traces = [
            self.drawing.show_trace(f"/trace/{k}", a.trace, a.max_deviation)
            for k, a in enumerate(self.runs)
        ]
        self._run_menu(gui)
        self.timeline = Timeline(gui, self.current.log.time, self.show)
        self.state_panel = StatePanel(gui, "Now")
        self.bscan = bscan_panel(gui, runs[0]) if len(runs) == 1 else None  # an episode's
        with gui.add_folder("Actuators"):
            self.actuators = self._actuator_panel(gui)
        self.info = StatePanel(gui, "Run")
        self.legend = gui.add_markdown("")
        self.cameras = CameraViews(server, runs[0].scene, self.robot)
        self.select(0)

    def _run_menu(self, gui: Any) -> None:
        self.menu = None
        if len(self.runs) > 1:
            labels = [a.run.label for a in self.runs]
            self.menu = gui.add_dropdown("run", labels, initial_value=labels[0])
            self.menu.on_update(lambda _e: self.select(labels.index(str(self.menu.value))))

    def _actuator_panel(self, gui: Any) -> ActuatorPanel:
        log = self.current.log
        n = log.sliders.shape[1]
        if self.robot is not None:
            names, units = self.robot.actuator_names, self.robot.actuator_units
            lower, upper = self.robot.lower, self.robot.upper
        else:
            labels = log.actuator_labels or tuple(f"s{i}_m" for i in range(n))
            names = tuple(lb.rsplit("_", 1)[0] for lb in labels)
            units = tuple("rad" if lb.endswith("_rad") else "m" for lb in labels)
            lower = upper = np.full(n, np.nan)
        all_s = np.vstack([a.log.sliders for a in self.runs])
        lo, hi = travel(np.asarray(lower), np.asarray(upper), all_s)
        return ActuatorPanel(gui, names, units, lo, hi)

    def select(self, k: int) -> None:
        """Show run k of the comparison (its trace, its timeline), at its first record."""
        with self.lock:
            self.current = self.runs[k]
            for j, handle in enumerate(self.traces):
                if handle is not None:
                    handle.visible = j == k
            self._info()
        self.timeline.times = self.current.log.time
        self.timeline.slider.max = float(self.current.log.time[-1])
        self.timeline.seek(float(self.current.log.time[0]))
        self.show(0)

    def _info(self) -> None:
        s = self.current.run.summary
        a = self.current
        self.info.show({
            "folder": str(a.run.folder), "robot": str(s.get("robot")),
            "method": str(s.get("method")), "plant": str(s.get("plant")),
            "status": str(s.get("status")), "records": f"{len(a.log):,}",
            "max RCM deviation": length(s.get("max_rcm_deviation_m") or float("nan")),
        })  # fmt: skip
        notes = "".join(f"  \n_{n}_" for n in self.notes)
        self.legend.content = (
            f"Tip trace colour: RCM deviation from 0 (green) to {length(a.max_deviation)} "
            f"(red); grey outside the eye. {a.trace.describe()}{notes}"
        )

    def show(self, index: int) -> None:
        """Show record `index` of the current run: robot, needle, markers, panels."""
        start = time.perf_counter()
        with self.lock, self.server.atomic():
            a = self.current
            i = min(max(int(index), 0), len(a.log) - 1)
            log = a.log
            q = log.joints[i]
            self.links.show(q, log.sliders[i])
            needle = needle_polyline(self.robot, q, log.base[i], log.tip[i])
            inside = bool(np.isfinite(log.trocar[i, 0]))
            self.drawing.show(needle, log.rcm[i] if inside else log.trocar[i], log.target_tip[i],
                              a.eye_offset[i])  # fmt: skip
            self.state_panel.show(self._figures(a, i))
            self.actuators.show(log.sliders[i])
            if self.bscan is not None:
                self.bscan.show(float(log.time[i]), i)
            self.index = i
            self.shows += 1
        self.show_time_s = time.perf_counter() - start

    def _figures(self, a: RunArrays, i: int) -> dict[str, str]:
        log = a.log
        names = log.phase_names
        phase = names[log.phase[i]] if 0 <= log.phase[i] < len(names) else "-"
        return {
            "phase": f"{phase} ({log.phase[i] + 1}/{len(names)})",
            "time": f"{log.time[i]:.3f} s (record {i + 1:,} of {len(log):,})",
            "RCM deviation": length(float(a.deviation[i])),
            "tip error": length(float(a.tip_error[i])),
            "lambda": f"{log.lam[i]:.4f}" if np.isfinite(log.trocar[i, 0]) else "-",
        }

    def state(self) -> dict[str, Any]:
        """The shown record, for tests and benchmarks: index, time [s], tip, needle base and
        RCM deviation [m], the number of records shown, the last show's wall time [s] and the
        B-scan frame shown (an episode's; -1 before the first, None without B-scans)."""
        with self.lock:
            log, i = self.current.log, self.index
            return {
                "run": self.current.run.label, "index": i, "time_s": float(log.time[i]),
                "tip_m": log.tip[i].tolist(), "base_m": log.base[i].tolist(),
                "rcm_deviation_m": float(self.current.deviation[i]), "shows": self.shows,
                "show_time_s": self.show_time_s, "playing": self.timeline.playing,
                "bscan_frame": None if self.bscan is None else self.bscan.frame,
                "eye_offset_m": self.current.eye_offset[i].tolist(),
            }  # fmt: skip

    def close(self) -> None:
        """Stop playback."""
        self.timeline.close()
