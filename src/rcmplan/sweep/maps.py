"""Retina maps of a sweep and the gain-search trade-off, as matplotlib PNG figures.

Each target is a dot at its ray's tilt from the insertion axis (sampling.py), in degrees:
reachability (converged, failed, out of the robot's reach, ray missing the retina), maximum RCM
deviation in [um] and control iterations. The dashed circle is the sampled cone.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from rcmplan.exceptions import require_extra
from rcmplan.sweep.gains import GainSearchResult
from rcmplan.sweep.runner import SweepResult
from rcmplan.sweep.sampling import MISSES_RETINA, REACHABLE, UNREACHABLE

UM = 1e6
CATEGORIES = (
    ("converged", "tab:green", "o"),
    ("motion failed", "tab:red", "o"),
    ("out of reach (robot)", "0.7", "o"),
    ("ray misses retina", "black", "x"),
)


def _plt() -> Any:
    mpl = require_extra("matplotlib", "plots")
    mpl.use("Agg")
    return require_extra("matplotlib.pyplot", "plots")


def _axes(plt: Any, result: SweepResult, title: str) -> tuple[Any, Any]:
    fig, ax = plt.subplots(figsize=(6.4, 5.6), layout="constrained")
    r = math.degrees(result.settings.region.max_angle)
    t = np.linspace(0.0, 2.0 * math.pi, 200)
    ax.plot(r * np.cos(t), r * np.sin(t), "k--", lw=0.6)
    ax.set_aspect("equal")
    ax.set_xlabel("tilt along e1 [deg]")
    ax.set_ylabel("tilt along e2 [deg]")
    ax.set_title(title)
    return fig, ax


def _save(plt: Any, fig: Any, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def categories(result: SweepResult) -> np.ndarray:
    """Category index per sampled target (index into CATEGORIES)."""
    status = result.sample.status
    conv = result.column("converged")
    cat = np.full(len(status), 2)
    cat[status == MISSES_RETINA] = 3
    cat[(status == REACHABLE) & (conv == 1.0)] = 0
    cat[(status == REACHABLE) & (conv != 1.0)] = 1
    return cat


def reachability_map(result: SweepResult, path: Path) -> Path:
    """Which retina targets converged, failed, or lie out of reach."""
    plt = _plt()
    tilt = np.degrees(result.sample.tilt)
    cat = categories(result)
    counts = result.sample.counts()
    fig, ax = _axes(plt, result, f"Reachability ({counts['reachable']} of {len(cat)} reachable)")
    for i, (label, colour, marker) in enumerate(CATEGORIES):
        m = cat == i
        if np.any(m):
            ax.scatter(*tilt[m].T, s=_size(len(cat)), c=colour, marker=marker,
                       label=f"{label} ({int(m.sum())})")  # fmt: skip
    ax.legend(loc="upper right", fontsize=8)
    return _save(plt, fig, path)


def value_map(result: SweepResult, path: Path, column: str, label: str, scale: float) -> Path:
    """A result column as colour over the reachable targets, unreachable ones in grey."""
    plt = _plt()
    tilt = np.degrees(result.sample.tilt)
    values = result.column(column) * scale
    ok = np.isfinite(values)
    fig, ax = _axes(plt, result, label)
    s = _size(len(values))
    out = result.sample.status == UNREACHABLE
    ax.scatter(*tilt[out].T, s=s, c="0.85", label="out of reach")
    if np.any(ok):
        sc = ax.scatter(*tilt[ok].T, s=s, c=values[ok], cmap="viridis")
        fig.colorbar(sc, ax=ax, label=label)
    ax.legend(loc="upper right", fontsize=8)
    return _save(plt, fig, path)


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
    """Mean iterations against max RCM deviation per candidate, the bound and the best."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.4, 4.8), layout="constrained")
    ev = search.evaluations
    dev = np.array([e.max_rcm_deviation_m for e in ev]) * UM
    it = np.array([e.mean_iterations for e in ev])
    feas = np.array([e.feasible for e in ev])
    ax.scatter(dev[feas], it[feas], c="tab:green", label="meets constraints")
    ax.scatter(dev[~feas], it[~feas], c="tab:red", marker="x", label="violates a constraint")
    ax.axvline(search.objective.rcm_bound_m * UM, color="k", ls="--", lw=0.8, label="RCM bound")
    if search.best is not None:
        b = search.best
        ax.scatter([b.max_rcm_deviation_m * UM], [b.mean_iterations], s=160, facecolors="none",
                   edgecolors="k", label="best")  # fmt: skip
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("max RCM deviation over the subsample [um]")
    ax.set_ylabel("mean control iterations per target")
    ax.set_title(f"Gain search ({search.mode}, {len(search.subsample_ids)} targets)")
    ax.legend(fontsize=8)
    return _save(plt, fig, path)


def _size(n: int) -> float:
    """Marker area in [pt^2] that keeps n dots readable."""
    return float(min(40.0, max(2.0, 4000.0 / max(n, 1))))
