"""Figures of a run (matplotlib, PNG), read only from the run log. Units in every label.

Time runs on the x-axis in [s] (the log's `time`: simulated time on every plant), with the
phases as labelled bands. Trocar coordinates are (e1, e2, n): n the insertion axis (trocar to
eye centre), e1 = n x z_base / |n x z_base|, e2 = n x e1, the frame the sweep maps use too.

- `rcm_deviation_envelope`: the largest RCM deviation in each control step (figs. 4.1, 4.2,
  4.4, 4.7 of the thesis), norm and components, against the bounds.
- `rcm_trace`: the RCM point in the trocar plane (e1, e2) with the port circle (figs. 4.3, 4.5).
- `tip_path`: the tip path in 3D with the named targets, commanded versus actual (fig. 4.6),
  and the tracking error over time.
- `method_comparison` (in `plots_compare`): every method, failed ones named.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.analysis import style
from rcmplan.analysis.style import BLACK, BLUE, GREEN, ORANGE, UM, VERMILLION
from rcmplan.control.log import RunLog
from rcmplan.exceptions import InvalidInputError
from rcmplan.scene.eye import Eye

Bound = tuple[str, float]  # label, value in [m]


def trocar_frame(eye: Eye) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(e1, e2, n) in the base frame: two unit axes normal to the insertion axis n, and n."""
    n = eye.axis
    e1 = np.cross(n, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(n, e1), n


def inside(log: RunLog, phase: str | None = None) -> RunLog:
    """The records where an RCM is held (optionally of one phase)."""
    mask = np.all(np.isfinite(log.trocar), axis=1)
    if phase is not None:
        if phase not in log.phase_names:
            raise InvalidInputError("phase", phase, f"one of {list(log.phase_names)}")
        mask &= log.phase == log.phase_names.index(phase)
    return log.select(mask)


def step_starts(log: RunLog) -> tuple[np.ndarray, np.ndarray]:
    """(first, last) record index of each control step: a run of records with the same phase
    and step index."""
    change = (np.diff(log.phase) != 0) | (np.diff(log.step) != 0)
    starts = np.flatnonzero(np.concatenate([[True], change]))
    return starts, np.append(starts[1:], len(log)) - 1


def step_envelope(log: RunLog, values: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(time of each control step's last record [s], max of values (N,) or (N, k) over the
    step's records)."""
    starts, ends = step_starts(log)
    return log.time[ends], np.maximum.reduceat(values, starts, axis=0)


def rcm_deviation_envelope(
    log: RunLog, eye: Eye, path: Path, bounds: Sequence[Bound] = (), phase: str | None = None
) -> Path:
    """Largest |p_rcm - trocar| per control step in um (log scale), with its components."""
    plt = style.plt()
    sub = inside(log, phase)
    e1, e2, n = trocar_frame(eye)
    dev = sub.rcm_deviation()
    cols = np.column_stack([np.linalg.norm(dev, axis=1), *(np.abs(dev @ a) for a in (e1, e2, n))])
    t, env = step_envelope(sub, cols * UM)
    fig, (strip, ax) = style.time_axes(plt, 1, 4.4)
    spans = style.phase_spans(sub)
    style.phase_strip(strip, spans)
    style.shade_phases(ax, spans)
    series = (("norm", BLACK, "-", 1.6), ("|e1|", BLUE, "--", 1.0),
              ("|e2|", ORANGE, "-.", 1.0), ("|n| (along the axis)", GREEN, ":", 1.2))  # fmt: skip
    floor = _log_floor(env[:, 0])
    for i, (name, colour, ls, lw) in enumerate(series):
        ax.plot(t, np.maximum(env[:, i], floor), color=colour, ls=ls, lw=lw, label=name)
    for (label, value), colour in zip(bounds, (VERMILLION, BLUE), strict=False):
        ax.axhline(value * UM, color=colour, lw=1.4, label=f"{label} {value * UM:.3g} um")
    ax.set_yscale("log")
    ax.set_ylim(bottom=floor)
    _note_floor(ax)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("max RCM deviation per step [um]")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), framealpha=0.9)
    title = "RCM deviation, largest per control step, trocar coordinates"
    strip.set_title(title + ("" if phase is None else f": {phase}"))
    return style.save(fig, path)


def _log_floor(norm_um: FloatArray) -> float:
    """Lower edge of a log axis: four decades below the peak (rounding noise sits below)."""
    peak = float(np.nanmax(norm_um)) if norm_um.size else 1.0
    return max(peak, 1e-9) * 1e-4


def _note_floor(ax: Any) -> None:
    ax.text(0.01, 0.02, "values below the axis are drawn on it", transform=ax.transAxes,
            fontsize=7, color="0.35", va="bottom")  # fmt: skip


def rcm_trace(log: RunLog, eye: Eye, path: Path, phase: str | None = None) -> Path:
    """The RCM point in the trocar plane (e1, e2) in um: to scale in the port, and zoomed."""
    plt = style.plt()
    sub = inside(log, phase)
    e1, e2, _ = trocar_frame(eye)
    dev = sub.rcm_deviation()
    u, v = dev @ e1 * UM, dev @ e2 * UM
    r = eye.trocar_radius * UM
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4.6), width_ratios=[1.0, 1.2])
    fig.subplots_adjust(left=0.08, right=0.97, top=0.92, bottom=0.12, wspace=0.3)
    a1.add_patch(plt.Circle((0, 0), r, fill=False, color=VERMILLION, lw=1.5, label="port"))
    a1.plot(u, v, ".", ms=2, color=BLACK, label="RCM point")
    a1.set_xlim(-1.15 * r, 1.15 * r)
    a1.set_ylim(-1.15 * r, 1.15 * r)
    a1.set_title(f"In the trocar port (radius {r:.0f} um), to scale")
    sc = a2.scatter(u, v, c=sub.time, s=4, cmap="cividis")
    fig.colorbar(sc, ax=a2, label="time [s]")
    a2.set_title(f"Zoomed: largest distance in the plane {np.nanmax(np.hypot(u, v)):.3g} um")
    a1.set_aspect("equal", adjustable="box")
    a2.set_aspect("equal", adjustable="datalim")
    for a in (a1, a2):
        a.set_xlabel("e1, across the trocar [um]")
        a.set_ylabel("e2, across the trocar [um]")
    a1.legend(loc="upper right")
    return style.save(fig, path)


def tip_path(log: RunLog, eye: Eye, targets: dict[str, FloatArray], path: Path) -> Path:
    """Tip path in 3D (mm): actual and commanded, named targets; tracking error over time."""
    plt = style.plt()
    fig = plt.figure(figsize=(11, 5.2))
    grid = fig.add_gridspec(2, 2, width_ratios=[1.15, 1.0], height_ratios=[1.4, 7.0],
                            left=0.0, right=0.98, top=0.92, bottom=0.1, wspace=0.25,
                            hspace=0.06)  # fmt: skip
    ax = fig.add_subplot(grid[:, 0], projection="3d")
    _eye_wireframe(ax, eye)
    tip, cmd = log.tip * 1e3, log.target_tip * 1e3
    ax.plot(*cmd.T, color=ORANGE, lw=2.2, ls="--", label="commanded (target_tip)")
    ax.plot(*tip.T, color=BLUE, lw=1.0, label="actual tip")
    ax.scatter(*(eye.port * 1e3), color=VERMILLION, s=30, label="trocar")
    for name, p in targets.items():
        q = np.asarray(p) * 1e3
        ax.scatter(*q, color=BLACK, s=12)
        ax.text(*q, f" {name}", fontsize=9)
    ax.set(xlabel="x_base [mm]", ylabel="y_base [mm]", zlabel="z_base [mm]")
    ax.set_aspect("equal")
    ax.set_title("Needle tip path, base frame")
    ax.legend(loc="upper left", fontsize=8)
    _tracking_error(fig, grid, log)
    return style.save(fig, path)


def _eye_wireframe(ax: Any, eye: Eye) -> None:
    u, v = np.mgrid[0 : 2 * np.pi : 25j, 0 : np.pi : 13j]
    r, c = eye.retina_radius * 1e3, eye.center * 1e3
    ax.plot_wireframe(
        c[0] + r * np.cos(u) * np.sin(v), c[1] + r * np.sin(u) * np.sin(v),
        c[2] + r * np.cos(v), color="0.8", lw=0.4,
    )  # fmt: skip


def _tracking_error(fig: Any, grid: Any, log: RunLog) -> None:
    strip = fig.add_subplot(grid[0, 1])
    ax = fig.add_subplot(grid[1, 1], sharex=strip)
    spans = style.phase_spans(log)
    style.phase_strip(strip, spans)
    style.shade_phases(ax, spans)
    _, ends = step_starts(log)
    err = np.linalg.norm(log.tip - log.target_tip, axis=1)[ends] * UM
    floor = _log_floor(err)
    ax.plot(log.time[ends], np.maximum(err, floor), color=BLUE, lw=1.0)
    ax.set_yscale("log")
    ax.set_ylim(bottom=floor)
    _note_floor(ax)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("|tip - commanded| at step end [um]")
    strip.set_title("Tip tracking error")
