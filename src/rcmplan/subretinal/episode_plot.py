"""The figure of one subretinal episode: the tip's depth over time with the layers and phases.

Depths are along the target's normal below the UNDISPLACED ILM [um], growing downwards: the
true ILM and RPE move with the wall; the target band moves with the ILM; the predicted ILM and
the depth limit (the estimated RPE less the margin) are what the controller used.
"""

from __future__ import annotations

from pathlib import Path

from rcmplan.analysis import style
from rcmplan.analysis.style import BLACK, BLUE, GREEN, ORANGE, PURPLE, UM, VERMILLION
from rcmplan.subretinal.episode import EpisodeResult


def depth_figure(result: EpisodeResult, path: Path) -> Path:
    """Draw the figure and write it as PNG at `path`."""
    plt = style.plt()
    s, layers, cfg = result.series, result.layers, result.settings
    t, wall = s["t_s"], s["wall_m"]
    tip = s["depth_vs_undeformed_m"] + wall  # below the undisplaced ILM
    fig, (strip, ax) = style.time_axes(plt, 1, height=4.6)
    spans = style.phase_spans(result.log)
    style.phase_strip(strip, spans)
    style.shade_phases(ax, spans)
    lo, hi = layers.band_m
    ax.fill_between(t, UM * (wall + lo), UM * (wall + hi), color=GREEN, alpha=0.25, lw=0,
                    label="target band")  # fmt: skip
    ax.plot(t, UM * wall, color=BLACK, lw=1.0, label="ILM (true)")
    ax.plot(t, UM * (wall + layers.thickness_m), color=VERMILLION, lw=1.0, label="RPE (true)")
    ax.plot(t, UM * s["predicted_m"], color=ORANGE, lw=0.9, ls="--",
            label=f"ILM ({cfg.compensation} prediction)")  # fmt: skip
    if cfg.depth_limit:
        limit = s["limit_m"] + layers.thickness_m - cfg.rpe_margin_m
        ax.plot(t, UM * limit, color=PURPLE, lw=0.9, ls=":", label="depth limit (estimated)")
    ax.plot(t, UM * tip, color=BLUE, lw=1.4, label="needle tip")
    ax.invert_yaxis()
    ax.set_xlabel("time [s]")
    ax.set_ylabel("depth below the undisplaced ILM [um]")
    style.legend_beside(ax, frameon=False)
    fig.suptitle(
        f"subretinal episode: {cfg.compensation}, iOCT {cfg.ioct_rate_hz:g} Hz, "
        f"latency {cfg.latency_s * 1e3:g} ms, breathing {cfg.breathing_m * UM:g} um"
    )
    return style.save(fig, path)
