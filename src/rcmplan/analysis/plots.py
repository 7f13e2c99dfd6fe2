"""Figures of a run (matplotlib, PNG), read only from the run log. Units in every label.

- `rcm_deviation_per_iteration`: RCM deviation x, y, z per control iteration (figs. 4.1, 4.2,
  4.4, 4.7 of the thesis).
- `rcm_trace`: the RCM point's trace over a phase, against the trocar port (figs. 4.3, 4.5).
- `tip_path_3d`: the tip path in 3D with the eye and the trocar (fig. 4.6).
- `method_comparison`: maximum RCM deviation, iterations and wall time per method.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rcmplan.control.log import RunLog
from rcmplan.exceptions import require_extra
from rcmplan.scene.eye import Eye

UM = 1e6


def _plt() -> Any:
    mpl = require_extra("matplotlib", "plots")
    mpl.use("Agg")
    return require_extra("matplotlib.pyplot", "plots")


def _inside(log: RunLog, phase: str | None) -> RunLog:
    mask = np.all(np.isfinite(log.trocar), axis=1)
    if phase is not None:
        if phase not in log.phase_names:
            from rcmplan.exceptions import InvalidInputError

            raise InvalidInputError("phase", phase, f"one of {list(log.phase_names)}")
        mask &= log.phase == log.phase_names.index(phase)
    return log.select(mask)


def rcm_deviation_per_iteration(log: RunLog, path: Path, phase: str | None = None) -> Path:
    """RCM deviation (x, y, z) in um per control iteration, phases inside the eye."""
    plt = _plt()
    sub = _inside(log, phase)
    dev = sub.rcm_deviation() * UM
    fig, ax = plt.subplots(figsize=(8, 4), layout="constrained")
    it = np.arange(len(sub))
    for i, (c, name) in enumerate(zip("rgb", "xyz", strict=True)):
        ax.plot(it, dev[:, i], color=c, lw=0.8, label=f"{name}_rcm")
    _phase_marks(ax, sub)
    ax.set_xlabel("control iteration (phases inside the eye)")
    ax.set_ylabel("RCM deviation [um]")
    ax.set_title(f"RCM deviation per iteration{'' if phase is None else f' — {phase}'}")
    ax.legend(loc="upper right")
    ax.grid(alpha=0.3)
    return _save(fig, path)


def _phase_marks(ax: Any, sub: RunLog) -> None:
    starts = np.flatnonzero(np.diff(sub.phase, prepend=-1))
    for s in starts[1:]:
        ax.axvline(s, color="0.8", lw=0.6)


def rcm_trace(log: RunLog, eye: Eye, path: Path, phase: str | None = None) -> Path:
    """The RCM point's trace in the plane normal to the trocar axis, in um, with its extent."""
    plt = _plt()
    sub = _inside(log, phase)
    n = eye.axis
    e1 = np.cross(n, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    dev = sub.rcm_deviation()
    u, v, w = dev @ e1 * UM, dev @ e2 * UM, dev @ n * UM
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4.5), layout="constrained")
    sc = a1.scatter(u, v, c=np.arange(len(u)), s=3, cmap="viridis")
    a1.set_xlabel("across the trocar, e1 [um]")
    a1.set_ylabel("across the trocar, e2 [um]")
    a1.set_aspect("equal", adjustable="datalim")
    a1.set_title(f"RCM trace (trocar radius {eye.trocar_radius * UM:.0f} um)")
    fig.colorbar(sc, ax=a1, label="iteration")
    a2.plot(w, lw=0.8, color="k")
    a2.set_xlabel("control iteration")
    a2.set_ylabel("along the trocar axis [um]")
    a2.set_title("RCM deviation along the axis")
    for a in (a1, a2):
        a.grid(alpha=0.3)
    return _save(fig, path)


def tip_path_3d(log: RunLog, eye: Eye, path: Path) -> Path:
    """The tip path in 3D (mm) with the eye's retina sphere and the trocar."""
    plt = _plt()
    fig = plt.figure(figsize=(7, 6), layout="constrained")
    ax = fig.add_subplot(projection="3d")
    u, v = np.mgrid[0 : 2 * np.pi : 30j, 0 : np.pi : 16j]
    r = eye.retina_radius * 1e3
    c = eye.center * 1e3
    ax.plot_wireframe(
        c[0] + r * np.cos(u) * np.sin(v),
        c[1] + r * np.sin(u) * np.sin(v),
        c[2] + r * np.cos(v),
        color="0.75",
        lw=0.4,
    )
    tip = log.tip * 1e3
    inside = np.all(np.isfinite(log.trocar), axis=1)
    ax.plot(*tip[~inside].T, ".", ms=1, color="tab:orange", label="free space")
    ax.plot(*tip[inside].T, lw=0.8, color="tab:blue", label="tip, RCM held")
    p = eye.port * 1e3
    ax.scatter(*p, color="red", s=30, label="trocar")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_zlabel("z [mm]")
    ax.set_title("Needle tip path")
    ax.legend(loc="upper left")
    return _save(fig, path)


def method_comparison(rows: Sequence[dict[str, Any]], path: Path) -> Path:
    """Bars per method: max RCM deviation [um], iterations, wall time [ms]."""
    plt = _plt()
    names = [r["method"] for r in rows]
    fig, axes = plt.subplots(1, 3, figsize=(11, 3.8), layout="constrained")
    series = [
        ("max RCM deviation [um]", [UM * (r["max_rcm_deviation_m"] or np.nan) for r in rows]),
        ("iterations", [r["iterations"] for r in rows]),
        ("wall time [ms]", [1e3 * r["wall_time_s"] for r in rows]),
    ]
    for ax, (label, vals) in zip(axes, series, strict=True):
        ax.bar(names, vals, color="tab:blue")
        ax.set_ylabel(label)
        ax.grid(axis="y", alpha=0.3)
        ax.tick_params(axis="x", rotation=30)
    fig.suptitle("Methods on the same procedure")
    return _save(fig, path)


def _save(fig: Any, path: Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    _plt().close(fig)
    return path
