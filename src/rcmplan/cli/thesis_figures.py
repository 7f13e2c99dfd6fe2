"""What the thesis reports for each chapter 4 experiment, and one figure per experiment that
puts it beside rcmplan's runs of both settings on the same axes.

The thesis's figures 4.1-4.7 carry no printed data; the reported values below are those its
text states, each with its source. docs/thesis.md discusses why they differ.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.analysis import style
from rcmplan.analysis.plots import step_envelope, step_starts
from rcmplan.analysis.style import BLUE, GREEN, ORANGE, UM, VERMILLION


class Reported(NamedTuple):
    """A figure the thesis reports: RCM deviation bound [m], iterations, time, sources."""

    rcm_deviation_m: float | None
    rcm_deviation_text: str
    iterations_text: str
    time_text: str
    source: str


REPORTED = {
    "pivot": Reported(30e-6, "x drift +-30 um (y, z roughly constant)",
                      "1350 for 500 steps (about 3 per step)", "about 3 min",
                      "sec. 4.1.2, figs. 4.2, 4.3"),
    "p3-p7": Reported(30e-6, "very similar to the alignment (+-30 um)", "not stated",
                      "roughly 2 min", "sec. 4.1.2, figs. 4.4, 4.5"),
    "spiral": Reported(100e-6, "below 0.1 mm, 'much more precise' than that precision",
                       "not stated", "28 s", "sec. 4.2, figs. 4.6, 4.7"),
}  # fmt: skip
COLOURS = {"thesis": ORANGE, "rcmplan": BLUE, "hypothesis": GREEN}
LABELS = {"thesis": "rcmplan, thesis setting", "rcmplan": "rcmplan, rcmplan setting",
          "hypothesis": "rcmplan, hypothesised V-REP setup"}  # fmt: skip


def step_numbers(log: Any) -> FloatArray:
    """The control step number (1, 2, ...) of each step with records, counted over the log's
    phases in order (a phase spans its largest step index + 1 steps)."""
    _, ends = step_starts(log)
    offsets = np.zeros(len(log.phase_names))
    acc = 0
    for ph in np.unique(log.phase):  # phase ids in run order
        offsets[ph] = acc
        acc += int(log.step[log.phase == ph].max()) + 1
    return np.asarray(offsets[log.phase[ends]] + log.step[ends] + 1, dtype=float)


def experiment_figure(key: str, title: str, outcomes: dict[str, Any], path: Path) -> Path:
    """Largest RCM deviation per control step of each setting (log scale, um) against the
    control step, with the thesis's reported bound shaded."""
    plt = style.plt()
    fig, ax = plt.subplots(figsize=(9, 5.4))
    fig.subplots_adjust(left=0.09, right=0.97, top=0.9, bottom=0.31)  # the legend below
    rep = REPORTED[key]
    if rep.rcm_deviation_m is not None:
        bound = rep.rcm_deviation_m * UM
        ax.axhspan(0.0, bound, color=VERMILLION, alpha=0.12, lw=0)
        ax.axhline(bound, color=VERMILLION, lw=1.4, zorder=style.BOUND_Z,
                   label=f"thesis: {rep.rcm_deviation_text} ({rep.source})")  # fmt: skip
    for setting, o in outcomes.items():
        inside = np.all(np.isfinite(o.log.trocar), axis=1)
        sub = o.log.select(inside)
        if len(sub) == 0:
            continue
        norm = np.linalg.norm(sub.rcm_deviation(), axis=1) * UM
        _, env = step_envelope(sub, norm)
        x = step_numbers(sub)
        per_step = o.iterations / max(o.steps, 1)
        label = f"{LABELS[setting]}: max {np.max(env):.3g} um, {per_step:.2f} iterations per step"
        if len(env) < o.steps:  # steps already within tolerance take no iteration, no record
            label += f"; a point per step that iterated ({len(env):,} of {o.steps:,})"
        ax.plot(x, np.maximum(env, 1e-6), color=COLOURS[setting], lw=1.2, label=label,
                marker="." if len(env) < o.steps else None, ms=2)  # fmt: skip
    ax.set_yscale("log")
    ax.set_xlabel("control step")
    ax.set_ylabel("max |p_rcm - trocar| per step [um]")
    ax.set_title(f"{title}: thesis and rcmplan", fontsize=11)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), fontsize=8)
    return style.save(fig, path)
