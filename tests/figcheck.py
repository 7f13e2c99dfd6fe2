"""Every figure readable as drawn: no legend over an axes of its figure, none cut off by the
figure's edge, and bound lines (a limit across the axes: `axhline`, `axvline`) beneath the data
lines, so that a curve riding a bound stays visible."""

from __future__ import annotations

from typing import Any


def legend_clashes(fig: Any) -> list[str]:
    """What the figure's legends overlap: an axes (named by its title or ylabel) or the figure's
    edge; empty if nothing. Each extent is laid out as it is asked for (the legend's own
    layout, the axes' position): no draw of the whole figure."""
    renderer = fig.canvas.get_renderer()
    legends = [*fig.legends, *(a.get_legend() for a in fig.axes if a.get_legend())]
    whole = fig.bbox
    out = []
    for legend in legends:
        box = legend.get_window_extent(renderer)
        for ax in fig.axes:
            if box.overlaps(ax.get_window_extent(renderer)):
                out.append(f"a legend over the axes {ax.get_title() or ax.get_ylabel()!r}")
        if (
            box.x0 < whole.x0 - 1
            or box.y0 < whole.y0 - 1
            or box.x1 > whole.x1 + 1
            or (box.y1 > whole.y1 + 1)
        ):
            out.append("a legend past the figure's edge")
    return out


def bounds_over_data(fig: Any) -> list[str]:
    """The axes (by title or ylabel) where a line across the axes (`axhline`, `axvline`: drawn
    in the axes' x or y transform) is not beneath every other line; empty if none."""
    out = []
    for ax in fig.axes:
        across = (ax.get_xaxis_transform(), ax.get_yaxis_transform())
        lines = ax.get_lines()
        bounds = [ln for ln in lines if ln.get_transform() in across]
        data = [ln for ln in lines if ln not in bounds]
        if (
            bounds
            and data
            and max(b.get_zorder() for b in bounds) >= min(d.get_zorder() for d in data)
        ):
            out.append(f"a bound line over the data of {ax.get_title() or ax.get_ylabel()!r}")
    return out
