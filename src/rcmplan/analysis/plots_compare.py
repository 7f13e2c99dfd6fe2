"""The method comparison chart: every method that was asked for, failed ones named."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rcmplan.analysis import style
from rcmplan.analysis.result import FINISHED
from rcmplan.analysis.style import BLUE, UM, VERMILLION
from rcmplan.analysis.units import fmt

PANELS = (  # title, key, factor from SI, log scale
    ("max RCM deviation [um]", "max_rcm_deviation_m", UM, False),
    ("control iterations", "iterations", 1.0, False),
    ("wall time, total [ms]", "wall_time_s", 1e3, True),
    ("wall time per iteration [us]", "wall_time_per_iteration_s", 1e6, True),
)


def failure_kind(status: str) -> str:
    """The error class of a status line ("ConvergenceError: ..." -> "ConvergenceError")."""
    return status.split(":", 1)[0].strip() or "failed"


def method_comparison(rows: Sequence[dict[str, Any]], path: Path) -> Path:
    """Bars per method, each with its value above it; a method that did not finish gets no bar
    but its name and its error. Numbers through `analysis.units.fmt`."""
    plt = style.plt()
    from matplotlib.ticker import FuncFormatter

    names = [r["method"] for r in rows]
    failed = [r["status"] not in FINISHED for r in rows]
    fig, axes = plt.subplots(1, len(PANELS), figsize=(12, 3.9))
    fig.subplots_adjust(left=0.05, right=0.99, top=0.84, bottom=0.2, wspace=0.3)
    x = np.arange(len(rows))
    for ax, (label, key, scale, log_scale) in zip(axes, PANELS, strict=True):
        vals = [np.nan if bad or r.get(key) is None else scale * r[key]
                for r, bad in zip(rows, failed, strict=True)]  # fmt: skip
        bars = ax.bar(x, vals, color=BLUE)
        # each bar's value above it (the axis cannot tell 7.6 from 8.9 on a log scale), with
        # room for it below the frame
        ax.bar_label(bars, [fmt(v) if np.isfinite(v) else "" for v in vals], fontsize=7,
                     padding=2)  # fmt: skip
        if log_scale and np.any(np.isfinite(vals)):
            _log_axis(ax, float(np.nanmin(vals)))
        top = float(np.nanmax(vals)) if np.any(np.isfinite(vals)) else math.nan
        if top > 0.0:
            ax.set_ylim(top=top * (1.6 if log_scale else 1.15))
        elif top == 0.0:  # every value 0: the bars on the floor, their labels above them
            ax.set_ylim(0.0, 1.0)
        ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: fmt(v)))
        for i in [j for j, bad in enumerate(failed) if bad]:
            ax.text(i, 0.04, f"failed: {failure_kind(rows[i]['status'])}", rotation=90,
                    ha="center", va="bottom", color=VERMILLION, fontsize=8,
                    transform=ax.get_xaxis_transform())  # fmt: skip
        ax.set_xticks(x, names, rotation=30)
        ax.set_xlim(-0.6, len(rows) - 0.4)
        for tick, bad in zip(ax.get_xticklabels(), failed, strict=True):
            tick.set_color(VERMILLION if bad else "black")
        ax.set_title(label, fontsize=10)
        ax.grid(axis="x", visible=False)
    fig.suptitle(comparison_title(rows))
    return style.save(fig, path)


def _log_axis(ax: Any, low: float) -> None:
    """A log y-axis from the whole decade below the smallest bar (so every bar shows its
    length), ticked at 1, 2 and 5 of each decade."""
    from matplotlib.ticker import LogLocator, NullFormatter

    ax.set_yscale("log")
    ax.set_ylim(bottom=10.0 ** math.floor(math.log10(low)))
    ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    ax.yaxis.set_minor_formatter(NullFormatter())


def comparison_title(rows: Sequence[dict[str, Any]]) -> str:
    """The chart title, naming every method that did not finish and its error."""
    bad = [f"{r['method']} ({failure_kind(r['status'])})" for r in rows
           if r["status"] not in FINISHED]  # fmt: skip
    broke = [r["method"] for r in rows if r["status"] == "limit_violated"]
    title = "Methods on the same procedure"
    title += f"; did not finish: {', '.join(bad)}" if bad else ""
    return title + (f"; beyond their bounds: {', '.join(broke)}" if broke else "")
