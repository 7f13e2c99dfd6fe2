"""Shared look of the figures: a colour-blind-safe palette, report-size fonts, phase bands.

The palette is Okabe and Ito's (2008), distinguishable with the common colour-vision
deficiencies; lines also differ in style where colour alone would carry meaning.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from rcmplan._atomic import atomic_path
from rcmplan.control.log import RunLog
from rcmplan.exceptions import require_extra

UM = 1e6
MM = 1e3

# Okabe-Ito: blue, orange, bluish green, vermillion, reddish purple, sky blue, yellow, black
BLUE, ORANGE, GREEN, VERMILLION, PURPLE, SKY, YELLOW, BLACK = (
    "#0072B2", "#E69F00", "#009E73", "#D55E00", "#CC79A7", "#56B4E9", "#F0E442", "#000000",
)  # fmt: skip
BAND_COLOURS = ("#EEEEEE", "#DDDDDD")
RC = {
    "font.size": 10,
    "axes.titlesize": 11,
    "axes.labelsize": 10,
    "legend.fontsize": 9,
    "xtick.labelsize": 9,
    "ytick.labelsize": 9,
    "axes.grid": True,
    "grid.alpha": 0.3,
}


def plt() -> Any:
    """matplotlib.pyplot on the Agg backend with the report style (the `plots` extra)."""
    mpl = require_extra("matplotlib", "plots")
    mpl.use("Agg")
    mpl.rcParams.update(RC)
    return require_extra("matplotlib.pyplot", "plots")


def save(fig: Any, path: Path) -> Path:
    """Write the figure as PNG (110 dpi, atomically) and close it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=110)
    finally:
        plt().close(fig)
    return path


def phase_spans(log: RunLog) -> list[tuple[str, float, float]]:
    """(name, start [s], end [s]) of each run of consecutive records of one phase.

    A phase starts one control period before its first record (the record is the state after
    the first command), so adjacent bands meet.
    """
    if len(log) == 0:
        return []
    starts = np.flatnonzero(np.diff(log.phase, prepend=-1))
    ends = np.append(starts[1:], len(log)) - 1
    dt = float(np.median(np.diff(log.time))) if len(log) > 1 else 0.0
    return [
        (log.phase_names[log.phase[s]], float(log.time[s]) - dt, float(log.time[e]))
        for s, e in zip(starts, ends, strict=True)
    ]


def phase_strip(ax: Any, spans: list[tuple[str, float, float]]) -> None:
    """Labelled phase bands on a thin axis above a time plot (shared x)."""
    width = (spans[-1][2] - spans[0][1]) if spans else 1.0
    for i, (name, t0, t1) in enumerate(spans):
        ax.axvspan(t0, t1, color=BAND_COLOURS[i % 2], lw=0)
        narrow = (t1 - t0) < 0.013 * len(name) * width
        ax.text(
            0.5 * (t0 + t1), 0.5, name, ha="center", va="center", fontsize=7 if narrow else 8,
            rotation=90 if narrow else 0,
        )  # fmt: skip
    ax.set_yticks([])
    ax.grid(False)
    ax.tick_params(axis="x", labelbottom=False)
    for side in ("top", "right", "left"):
        ax.spines[side].set_visible(False)


def shade_phases(ax: Any, spans: list[tuple[str, float, float]]) -> None:
    """The same alternating bands behind a time plot (no labels: the strip carries them)."""
    for i, (_, t0, t1) in enumerate(spans):
        ax.axvspan(t0, t1, color=BAND_COLOURS[i % 2], lw=0, alpha=0.5, zorder=0)


def time_axes(plot: Any, n_rows: int = 1, height: float = 4.2) -> tuple[Any, list[Any]]:
    """A figure with a phase strip on top and n_rows time plots below, all sharing x."""
    fig, axes = plot.subplots(
        n_rows + 1, 1, figsize=(10, height), sharex=True,
        gridspec_kw={"height_ratios": [1.4, *([7.0] * n_rows)], "hspace": 0.08},
    )  # fmt: skip
    # A fixed layout (room on the right for a legend): matplotlib's constrained layout would
    # cost about a third of a second per figure.
    fig.subplots_adjust(left=0.08, right=0.76, top=0.92, bottom=0.11)
    return fig, list(axes)
