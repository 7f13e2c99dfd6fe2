"""Figures of a run (matplotlib, PNG), read only from the run log. Units in every label.

Time runs on the x-axis in [s] (the log's `time`: simulated time on every plant), with the
phases as labelled bands. Trocar coordinates are (e1, e2, n): n the insertion axis (trocar to
eye centre), e1 = n x z_base / |n x z_base|, e2 = n x e1, the frame the sweep maps use too.

- `rcm_deviation_envelope`: the largest RCM deviation in each control step (figs. 4.1, 4.2,
  4.4, 4.7 of the thesis), norm and components, against the bounds.
- `rcm_trace`: the RCM point in the trocar plane (e1, e2) with the port circle (figs. 4.3, 4.5).
- `tip_path`: the tip path in 3D with the named targets, commanded versus actual (fig. 4.6),
  and over time the tracking error (|tip - target| over every iteration, its largest in each
  control step) and the waypoint tip error (at the step's end) against the reach bound.

Bounds are drawn beneath the data, and legends and notes outside the axes, so no line hides
under a bound and no legend covers a line.
- `method_comparison` (in `plots_compare`): every method, failed ones named.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.analysis import style
from rcmplan.analysis.style import BLACK, BLUE, GREEN, ORANGE, PURPLE, UM, VERMILLION
from rcmplan.analysis.units import fmt
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
    for i, (name, colour, ls, lw) in enumerate(series):  # the norm on top of its components
        ax.plot(t, np.maximum(env[:, i], floor), color=colour, ls=ls, lw=lw, label=name,
                zorder=4 if i == 0 else 3)  # fmt: skip
    _bounds(ax, bounds)
    ax.set_yscale("log")
    ax.set_ylim(bottom=floor)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("max RCM deviation per step [um]")
    style.legend_beside(ax, title=FLOOR_NOTE, title_fontsize=7)
    title = "RCM deviation, largest per control step, trocar coordinates"
    strip.set_title(title + ("" if phase is None else f": {phase}"))
    return style.save(fig, path)


def _log_floor(norm_um: FloatArray) -> float:
    """Lower edge of a log axis: four decades below the peak (rounding noise sits below)."""
    peak = float(np.nanmax(norm_um)) if norm_um.size else 1.0
    return max(peak, 1e-9) * 1e-4


FLOOR_NOTE = "values below the axis are drawn on it"


def _bounds(ax: Any, bounds: Sequence[Bound]) -> None:
    """Horizontal bound lines in [um] beneath the data (a line at the bound stays visible)."""
    for (label, value), colour in zip(bounds, (VERMILLION, PURPLE), strict=False):
        ax.axhline(value * UM, color=colour, lw=1.3, ls=(0, (5, 2)), zorder=2,
                   label=f"{label} {fmt(value, 'um')} um")  # fmt: skip


def rcm_trace(log: RunLog, eye: Eye, path: Path, phase: str | None = None) -> Path:
    """The RCM point in the trocar plane (e1, e2) in um: to scale in the port, and zoomed."""
    plt = style.plt()
    sub = inside(log, phase)
    e1, e2, _ = trocar_frame(eye)
    dev = sub.rcm_deviation()
    u, v = dev @ e1 * UM, dev @ e2 * UM
    r = eye.trocar_radius * UM
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4.6), width_ratios=[1.0, 1.2])
    fig.subplots_adjust(left=0.08, right=0.97, top=0.92, bottom=0.2, wspace=0.3)
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
        a.locator_params(axis="x", nbins=5)  # tick labels such as -0.075 do not run together
    a1.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2)  # below, off the port
    return style.save(fig, path)


def tip_path(
    log: RunLog, eye: Eye, targets: dict[str, FloatArray], path: Path,
    bounds: Sequence[Bound] = (),
) -> Path:  # fmt: skip
    """Tip path in 3D (mm): actual and commanded, named targets; over time the tracking error
    and the waypoint tip error, against `bounds` (the reach bound, `analysis.limits`)."""
    plt = style.plt()
    fig = plt.figure(figsize=(11, 5.6))
    grid = fig.add_gridspec(2, 2, width_ratios=[1.15, 1.0], height_ratios=[1.4, 7.0],
                            left=0.0, right=0.98, top=0.93, bottom=0.27, wspace=0.25,
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
    ax.locator_params(nbins=4)  # an axis shortened by the equal aspect keeps its labels apart
    ax.set_title("Needle tip path, base frame")
    fig.legend(*ax.get_legend_handles_labels(), loc="lower left", bbox_to_anchor=(0.04, 0.1),
               ncol=3, fontsize=8)  # fmt: skip
    _tip_errors(fig, grid, log, bounds)
    return style.save(fig, path)


def _eye_wireframe(ax: Any, eye: Eye) -> None:
    u, v = np.mgrid[0 : 2 * np.pi : 25j, 0 : np.pi : 13j]
    r, c = eye.retina_radius * 1e3, eye.center * 1e3
    ax.plot_wireframe(
        c[0] + r * np.cos(u) * np.sin(v), c[1] + r * np.sin(u) * np.sin(v),
        c[2] + r * np.cos(v), color="0.8", lw=0.4,
    )  # fmt: skip


def tip_errors(log: RunLog) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Per control step: the time of its last record [s], the largest |tip - target_tip| over
    its iterations (the tracking error, whose maximum the phase table reports) and the value at
    its last record (the waypoint tip error, `analysis.limits.waypoints`), in [m]."""
    err = np.linalg.norm(log.tip - log.target_tip, axis=1)
    t, tracking = step_envelope(log, err)
    return t, tracking, err[step_starts(log)[1]]


def _tip_errors(fig: Any, grid: Any, log: RunLog, bounds: Sequence[Bound]) -> None:
    """The tracking error and the waypoint tip error over time in [um], against `bounds`."""
    strip = fig.add_subplot(grid[0, 1])
    ax = fig.add_subplot(grid[1, 1], sharex=strip)
    spans = style.phase_spans(log)
    style.phase_strip(strip, spans)
    style.shade_phases(ax, spans)
    t, tracking, waypoint = tip_errors(log)
    floor = _log_floor(tracking * UM)
    ax.plot(t, np.maximum(tracking * UM, floor), color=BLACK, lw=1.0, zorder=3,
            label="tracking error, largest in the step")  # fmt: skip
    ax.plot(t, np.maximum(waypoint * UM, floor), color=GREEN, lw=1.6, ls=(0, (3, 1.5)),
            zorder=4, label="waypoint tip error, at the step's end")  # fmt: skip
    _bounds(ax, bounds)
    ax.set_yscale("log")
    ax.set_ylim(bottom=floor)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("|tip - commanded point| [um]")
    ax.legend(loc="upper left", bbox_to_anchor=(0.0, -0.16), ncol=2, fontsize=8,
              title=FLOOR_NOTE, title_fontsize=7)  # fmt: skip
    strip.set_title("Tip error against the commanded point")
