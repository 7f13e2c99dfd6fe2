"""Retina maps of a sweep and the gain-search trade-off, as matplotlib PNG figures.

Each target is a dot where its ray meets the retina, in fundus coordinates (`fundus.py`): the
retina unrolled about the point opposite the trocar, arc lengths in [mm], +z_base up. Maps:
reachability with each unreachable target coloured by its cause (actuator travel, singular
margin, RCM cone, eye wall), maximum RCM deviation in [um] and control iterations. The dashed
curve is the edge of the sampled cone.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from rcmplan.analysis import style
from rcmplan.analysis.style import BLACK, BLUE, GREEN, ORANGE, PURPLE, SKY, VERMILLION
from rcmplan.scene.eye import Eye
from rcmplan.sweep import fundus
from rcmplan.sweep.gains import GainSearchResult
from rcmplan.sweep.runner import SweepResult
from rcmplan.sweep.sampling import UNREACHABLE

UM = 1e6
# colour and marker per fundus.CAUSES entry (Okabe-Ito, markers differ too)
STYLES = ((GREEN, "o"), (VERMILLION, "X"), (ORANGE, "s"), (PURPLE, "D"), (SKY, "^"),
          ("0.6", "v"), (BLACK, "x"))  # fmt: skip
ORIENTATION = "fundus view about the point opposite the trocar; up = +z_base"


def _eye(result: SweepResult) -> Eye:
    motion = result.settings.motion
    return motion.eye(motion.model())


def _axes(plt: Any, result: SweepResult, eye: Eye, title: str) -> tuple[Any, Any]:
    fig, ax = plt.subplots(figsize=(7.6, 6.0))
    fig.subplots_adjust(left=0.1, right=0.72, top=0.9, bottom=0.1)
    edge = fundus.cone_edge_mm(eye, result.settings.region.max_angle)
    ax.plot(*edge.T, "k--", lw=0.7, label="sampled cone")
    ax.plot([0.0], [0.0], "+", color=BLACK, ms=10)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("along e1, horizontal [mm on the retina]")
    ax.set_ylabel("towards +z_base [mm on the retina]")
    ax.set_title(f"{title}\n{ORIENTATION}", fontsize=10)
    return fig, ax


def reachability_map(result: SweepResult, path: Path) -> Path:
    """Which retina targets converged, failed, or are out of reach, and why."""
    plt = style.plt()
    eye = _eye(result)
    xy = fundus.fundus_mm(result.sample.points, eye)
    cause = fundus.causes(result.sample, result.column("converged"))
    counts = result.sample.counts()
    fig, ax = _axes(plt, result, eye, f"Reachability: {counts['reachable']} of {len(cause)} "
                    "targets reachable")  # fmt: skip
    for i, (label, (colour, marker)) in enumerate(zip(fundus.CAUSES, STYLES, strict=True)):
        m = cause == i
        if np.any(m):
            note = ", no retina point: not drawn" if i == fundus.WALL else ""
            ax.scatter(*xy[m].T, s=_size(len(cause)), c=colour, marker=marker,
                       label=f"{label} ({int(m.sum())}{note})")  # fmt: skip
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, title="cause")
    return style.save(fig, path)


def value_map(result: SweepResult, path: Path, column: str, label: str, scale: float) -> Path:
    """A result column as colour over the reachable targets, unreachable ones in grey."""
    plt = style.plt()
    eye = _eye(result)
    xy = fundus.fundus_mm(result.sample.points, eye)
    values = result.column(column) * scale
    ok = np.isfinite(values)
    fig, ax = _axes(plt, result, eye, label)
    s = _size(len(values))
    out = result.sample.status == UNREACHABLE
    ax.scatter(*xy[out].T, s=s, c="0.85", label="out of reach")
    if np.any(ok):
        sc = ax.scatter(*xy[ok].T, s=s, c=values[ok], cmap="cividis")
        fig.colorbar(sc, ax=ax, label=label, shrink=0.8)
    ax.legend(loc="upper left", bbox_to_anchor=(1.25, 1.0), fontsize=8)
    return style.save(fig, path)


def sweep_maps(result: SweepResult, folder: Path) -> dict[str, Path]:
    """reachability.png, rcm_deviation.png and iterations.png in folder."""
    return {
        "reachability": reachability_map(result, folder / "reachability.png"),
        "rcm_deviation": value_map(
            result, folder / "rcm_deviation.png", "max_rcm_deviation_m",
            "max RCM deviation [um]", UM,
        ),
        "iterations": value_map(
            result, folder / "iterations.png", "iterations", "control iterations per target", 1.0
        ),
    }  # fmt: skip


def gain_tradeoff(search: GainSearchResult, path: Path) -> Path:
    """Mean iterations against max RCM deviation per candidate, the bound and the best; each
    point labelled with its candidate (k_task, k_rcm, step in mm)."""
    plt = style.plt()
    fig, ax = plt.subplots(figsize=(9.6, 5.2))
    fig.subplots_adjust(left=0.1, right=0.75, top=0.9, bottom=0.12)  # the legend beside
    ev = search.evaluations
    dev = np.array([e.max_rcm_deviation_m for e in ev]) * UM
    it = np.array([e.mean_iterations for e in ev])
    feas = np.array([e.feasible for e in ev])
    if feas.any():
        ax.scatter(dev[feas], it[feas], c=BLUE, label="meets constraints")
    if (~feas).any():
        ax.scatter(dev[~feas], it[~feas], c=VERMILLION, marker="x", label="violates a constraint")
    label_candidates(ax, ev, dev, it)
    bound, right = search.objective.rcm_bound_m * UM, float(np.nanmax(dev)) * 3.0
    beyond = "\n(beyond the right edge)" if bound > right else ""
    ax.axvline(bound, color="k", ls="--", lw=0.8, label=f"RCM bound {bound:.3g} um{beyond}")
    if search.best is not None:
        b = search.best
        ax.scatter([b.max_rcm_deviation_m * UM], [b.mean_iterations], s=160, facecolors="none",
                   edgecolors="k", label="best")  # fmt: skip
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(top=float(np.nanmax(it)) * 3.0)  # room for the labels
    ax.set_xlim(right=right)
    ax.set_xlabel("max RCM deviation over the subsample [um]")
    ax.set_ylabel("mean control iterations per target")
    ax.set_title(f"Gain search ({search.mode}, {len(search.subsample_ids)} targets); "
                 "labels: k_task/k_rcm/step [mm]", fontsize=10)  # fmt: skip
    style.legend_beside(ax, fontsize=8)
    return style.save(fig, path)


def label_candidates(ax: Any, ev: Any, dev: np.ndarray, it: np.ndarray) -> None:
    """One label per plotted point; candidates within 0.05 decade of each other share it."""
    groups: list[tuple[float, float, list[str]]] = []
    for e, x, y in zip(ev, dev, it, strict=True):
        c = e.candidate
        text = f"{c.k_task:.3g}/{c.k_rcm:.3g}/{1e3 * c.step_position:.3g}"
        lx, ly = float(np.log10(x)), float(np.log10(y))
        near = [g for g in groups if abs(g[0] - lx) < 0.05 and abs(g[1] - ly) < 0.05]
        if near:
            near[0][2].append(text)
        else:
            groups.append((lx, ly, [text]))
    for lx, ly, labels in groups:
        text = "\n".join(labels[:3] + ([f"+{len(labels) - 3} more"] if len(labels) > 3 else []))
        ax.annotate(text, (10.0**lx, 10.0**ly), fontsize=7, xytext=(4, 2),
                    textcoords="offset points", va="bottom")  # fmt: skip


def _size(n: int) -> float:
    """Marker area in [pt^2] that keeps n dots readable."""
    return float(min(40.0, max(2.0, 4000.0 / max(n, 1))))
