"""Figures of a session (matplotlib, PNG), units in every label; released periods shaded.

- `input_vs_tip`: the scaled input, the filtered desired tip, the intended motion and the tip,
  per eye-frame axis [mm] over time [s].
- `tremor_psd`: power spectral density (Welch) of the scaled input and of the tip, 0-30 Hz,
  the 6-16 Hz band marked.
- `rcm_deviation`: distance from the trocar to the needle line [um] with the RCM limit.
- `retina_distance`: tip and desired tip distance to the retina [mm] with the margin.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from scipy import signal

from rcmplan._validate import FloatArray
from rcmplan.analysis import style
from rcmplan.analysis.style import BLACK, BLUE, MM, ORANGE, SKY, UM, VERMILLION
from rcmplan.teleop import metrics
from rcmplan.teleop.run import TeleopResult
from rcmplan.teleop.violations import retina_distance

PSD_MAX_HZ = 30.0
PSD_SEGMENT = 2048  # samples per Welch segment (2 s at 1 kHz: 0.5 Hz resolution)


def _released(ax: Any, t: FloatArray, engaged: np.ndarray) -> None:
    """Grey bands over released periods."""
    edges = np.flatnonzero(np.diff(np.concatenate([[1], engaged.astype(int), [1]])))
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        ax.axvspan(t[a], t[min(b, len(t)) - 1], color="#DDDDDD", lw=0, zorder=0)


def mapped_input(result: TeleopResult) -> FloatArray:
    """The raw master position through the clutch and the scaling (N, 3) [m], base frame."""
    session = result.session
    to_tip = session.pipeline.scaling.rotation / result.settings.scale
    return metrics.reference(result.log.tip, result.trace.segment, result.trace.master, to_tip)


def input_vs_tip(result: TeleopResult, path: Path) -> Path:
    """Per eye-frame axis: scaled input, desired, intended and tip over time."""
    plt = style.plt()
    eye = result.session.eye
    R = result.session.pipeline.scaling.rotation
    t, trace = result.log.time, result.trace

    def eye_mm(p: FloatArray) -> FloatArray:
        return np.asarray((p - eye.center) @ R * MM)

    fig, axes = plt.subplots(3, 1, figsize=(10, 7), sharex=True)
    lines = [(mapped_input(result), "input, scaled", SKY, "-", 0.6),
             (trace.desired, "desired (filtered)", ORANGE, "-", 1.0),
             (result.log.tip, "tip", BLUE, "-", 1.2)]  # fmt: skip
    if result.intended is not None:
        to_tip = R / result.settings.scale
        ref = metrics.reference(result.log.tip, trace.segment, result.intended, to_tip)
        lines.append((ref, "intended, scaled", BLACK, "--", 0.9))
    for i, ax in enumerate(axes):
        _released(ax, t, trace.engaged)
        for p, label, colour, ls, lw in lines:
            ax.plot(t, eye_mm(p)[:, i], color=colour, ls=ls, lw=lw, label=label)
        ax.set_ylabel(f"{'xyz'[i]} [mm]")
    fig.suptitle(f"Input versus tip, eye frame (scale {result.settings.scale:g}, "
                 f"filter {result.settings.filter}); grey: clutch released")  # fmt: skip
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper center", ncols=4, bbox_to_anchor=(0.5, 0.955))
    fig.subplots_adjust(top=0.88, bottom=0.08, hspace=0.12)
    axes[-1].set_xlabel("time [s]")
    return style.save(fig, path)


def psd(x: FloatArray, engaged: np.ndarray, rate: float) -> tuple[FloatArray, FloatArray]:
    """(frequencies [Hz], PSD summed over the axes [m^2/Hz]) of x (N, 3) over the engaged
    runs at least one Welch segment long, averaged by length (empty if there is none)."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], engaged.astype(int), [0]])))
    total, weight, f = None, 0, np.zeros(0)
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        if b - a < PSD_SEGMENT:
            continue
        f, p = signal.welch(x[a:b], fs=rate, nperseg=PSD_SEGMENT, axis=0, detrend="linear")
        p = p.sum(axis=1) * (b - a)
        total = p if total is None else total + p
        weight += b - a
    return (f, total / weight) if total is not None else (f, np.zeros(0))


def tremor_psd(result: TeleopResult, path: Path) -> Path:
    """PSD of the scaled input and of the tip, 0-30 Hz."""
    plt = style.plt()
    rate, engaged = result.settings.rate_hz, result.trace.engaged
    fig, ax = plt.subplots(figsize=(10, 4.5))
    fig.subplots_adjust(left=0.08, right=0.74, top=0.9, bottom=0.12)  # the legend beside
    for x, label, colour in ((mapped_input(result), "input, scaled", VERMILLION),
                             (result.log.tip, "tip", BLUE)):  # fmt: skip
        f, p = psd(np.nan_to_num(x), engaged, rate)
        keep = f <= PSD_MAX_HZ
        if p.size:
            ax.semilogy(f[keep], p[keep] * UM**2, color=colour, label=label)
    lo, hi = metrics.BAND_HZ
    ax.axvspan(lo, hi, color="#EEEEEE", zorder=0, label=f"tremor band {lo:g}-{hi:g} Hz")
    ax.set_xlim(0, PSD_MAX_HZ)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("PSD, sum of x, y, z [um^2/Hz]")
    ax.set_title(f"Tremor before and after the pipeline (filter {result.settings.filter})")
    style.legend_beside(ax)
    return style.save(fig, path)


def rcm_deviation(result: TeleopResult, path: Path) -> Path:
    """Distance from the trocar to the needle line over time, with the limits."""
    plt = style.plt()
    log, fx = result.log, result.settings.fixtures
    fig, ax = plt.subplots(figsize=(12, 3.8))
    fig.subplots_adjust(left=0.07, right=0.8, top=0.88, bottom=0.14)  # the legend beside
    _released(ax, log.time, result.trace.engaged)
    ax.plot(log.time, np.linalg.norm(log.rcm - log.trocar, axis=1) * UM, color=BLUE,
            lw=0.8, label="RCM deviation")  # fmt: skip
    z = style.BOUND_Z
    ax.axhline(fx.rcm_limit * UM, color=VERMILLION, ls="--", zorder=z, label="RCM limit")
    ax.axhline(fx.rcm_tolerance * UM, color=ORANGE, ls=":", zorder=z, label="QP RCM tolerance")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("RCM deviation [um]")
    ax.set_title(f"RCM deviation ({result.settings.plant} plant)")
    style.legend_beside(ax)
    return style.save(fig, path)


def retina_plot(result: TeleopResult, path: Path) -> Path:
    """Tip and desired tip distance to the retina over time, with the margin."""
    plt = style.plt()
    eye, log = result.session.eye, result.log
    fig, ax = plt.subplots(figsize=(12, 3.8))
    fig.subplots_adjust(left=0.07, right=0.8, top=0.88, bottom=0.14)  # the legend beside
    _released(ax, log.time, result.trace.engaged)
    ax.plot(log.time, retina_distance(eye, result.trace.desired) * MM, color=ORANGE, lw=0.8,
            label="desired tip")  # fmt: skip
    ax.plot(log.time, retina_distance(eye, log.tip) * MM, color=BLUE, lw=1.2, label="tip")
    ax.axhline(result.settings.fixtures.retina_margin * MM, color=VERMILLION, ls="--",
               zorder=style.BOUND_Z, label="no-go margin")  # fmt: skip
    ax.axhline(0.0, color=BLACK, lw=0.8, zorder=style.BOUND_Z, label="retina")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("distance to the retina [mm]")
    ax.set_title("Retina no-go margin: the desired tip may pass it, the tip may not")
    style.legend_beside(ax)
    return style.save(fig, path)


FIGURES = {
    "input_vs_tip": input_vs_tip,
    "tremor_psd": tremor_psd,
    "rcm_deviation": rcm_deviation,
    "retina_distance": retina_plot,
}
