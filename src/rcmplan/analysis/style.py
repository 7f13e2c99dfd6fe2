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


BOUND_Z = 1.5  # zorder of a bound line: beneath a data line's 2, so a curve riding it shows


def legend_beside(ax: Any, **options: Any) -> Any:
    """The axes' legend to their right, outside them (the figure leaves room for it, by
    `subplots_adjust(right=...)`): never over the data."""
    return ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), **options)


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
    """Labelled phase bands on a thin axis above a time plot (shared x). A label too long for
    its band turns upright; labels that would overlap move apart, with a line to their band."""
    if not spans:
        ax.set_yticks([])
        return
    t0, t1 = spans[0][1], spans[-1][2]
    box = ax.get_position()
    per_inch = 1.1 * max(t1 - t0, 1e-12) / (box.width * ax.figure.get_figwidth())  # [s/in]
    sizes, widths = [], []
    for name, a, b in spans:
        flat = 0.55 * 8 / 72 * len(name) * per_inch  # the label's width lying down, in [s]
        sizes.append(8 if flat < 0.95 * (b - a) else 7)
        widths.append(flat if sizes[-1] == 8 else 1.3 * 7 / 72 * per_inch)
    centres = [0.5 * (a + b) for _, a, b in spans]
    for i, ((name, a, b), x) in enumerate(zip(spans, spread(centres, widths), strict=True)):
        ax.axvspan(a, b, color=BAND_COLOURS[i % 2], lw=0)
        moved = abs(x - centres[i]) > 0.5 * widths[i]
        ax.annotate(
            name, xy=(centres[i], 0.0), xytext=(x, 0.55), ha="center", va="center",
            fontsize=sizes[i], rotation=0 if sizes[i] == 8 else 90,
            arrowprops={"arrowstyle": "-", "lw": 0.5, "color": "0.4"} if moved else None,
        )  # fmt: skip
    ax.set_yticks([])
    ax.grid(False)
    ax.tick_params(axis="x", labelbottom=False)
    for side in ("top", "right", "left"):
        ax.spines[side].set_visible(False)


def spread(centres: list[float], widths: list[float]) -> list[float]:
    """Label centres, as close to `centres` (ascending) as labels of `widths` side by side allow:
    each run of crowded labels is laid edge to edge, centred on its members' own places."""
    c, w = np.asarray(centres, dtype=float), np.asarray(widths, dtype=float)
    runs: list[tuple[int, int]] = []  # [first, last) label of each run

    def left(run: tuple[int, int]) -> float:
        """The left edge of a run laid edge to edge with its mean offset zero."""
        i, j = run
        offsets = np.cumsum(w[i:j]) - 0.5 * w[i:j]  # each label's centre from the run's edge
        return float(np.mean(c[i:j] - offsets))

    for k in range(len(c)):
        runs.append((k, k + 1))
        while len(runs) > 1 and left(runs[-2]) + w[runs[-2][0] : runs[-2][1]].sum() > left(
            runs[-1]
        ):
            (i, _), (_, j) = runs[-2], runs.pop()
            runs[-1] = (i, j)
    out = [left(r) + np.cumsum(w[r[0] : r[1]]) - 0.5 * w[r[0] : r[1]] for r in runs]
    return [float(x) for x in np.concatenate(out)] if out else []


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
