"""The curves of a batch of subretinal episodes: per method, the success rate and the median
hover tracking RMS against the drawn iOCT volume rate and latency (`episode_report.curve`).
Each point is a bin's value at the bin's centre (geometric for the rate); empty bins are left
out; the number of episodes per bin is in summary.json."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from rcmplan.analysis import style
from rcmplan.analysis.style import BLUE, GREEN, ORANGE, UM, VERMILLION

METHOD_STYLE = {"none": (VERMILLION, ":", "x"), "hold": (ORANGE, "--", "s"),
                "fft": (GREEN, "-.", "^"), "kalman": (BLUE, "-", "o")}  # fmt: skip
AXES = {"ioct_rate_hz": ("iOCT volume rate [Hz]", 1.0, True),
        "latency_s": ("iOCT latency [ms]", 1e3, False)}  # fmt: skip


def _centres(edges: list[float], log: bool) -> Any:
    e = np.asarray(edges, dtype=float)
    return np.sqrt(e[:-1] * e[1:]) if log and e[0] > 0 else 0.5 * (e[:-1] + e[1:])


def curve_figure(curves: dict[str, Any], name: str, path: Path) -> Path:
    """Success rate and median tracking RMS against the condition `name` (a key of AXES)."""
    plt = style.plt()
    label, scale, log = AXES[name]
    data = curves[name]
    x = scale * _centres(data["edges"], log)
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7.5, 6.0), sharex=True)
    fig.subplots_adjust(left=0.11, right=0.78, top=0.92, bottom=0.1, hspace=0.1)
    for method, c in data["methods"].items():
        colour, ls, marker = METHOD_STYLE.get(method, ("#000000", "-", "."))
        for ax, key, unit in ((top, "success_rate", 100.0), (bottom, "tracking_rms_m_median", UM)):
            y = np.array([np.nan if v is None else unit * v for v in c[key]])
            ax.plot(x, y, color=colour, ls=ls, marker=marker, label=method)
    top.set_ylabel("success rate [%]")
    top.set_ylim(-5, 105)
    bottom.set_ylabel("hover tracking RMS, median [um]")
    bottom.set_xlabel(label)
    if log:
        bottom.set_xscale("log")
    edges = scale * np.asarray(data["edges"], dtype=float)
    if edges[-1] > edges[0]:  # ticks at the bin edges
        bottom.set_xlim(edges[0], edges[-1])
        bottom.set_xticks(edges, [f"{v:.3g}" for v in edges])
        bottom.minorticks_off()
    style.legend_beside(top, frameon=False)
    total = sum(sum(c["episodes"]) for c in data["methods"].values())
    fig.suptitle(f"subretinal episodes against the {label.split(' [')[0]} ({total} runs)")
    return style.save(fig, path)


def curve_figures(curves: dict[str, Any], folder: Path) -> dict[str, Path]:
    """Both figures in `folder`: curves_ioct_rate.png and curves_latency.png."""
    files = {"ioct_rate_hz": "curves_ioct_rate.png", "latency_s": "curves_latency.png"}
    return {name: curve_figure(curves, name, folder / f) for name, f in files.items()}
