"""The phases of a subretinal episode and the depth commanded in each (`episode` module
docstring), for many periods at once."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.exceptions import InvalidInputError
from rcmplan.subretinal.episode_settings import EpisodeSettings
from rcmplan.subretinal.layers import RetinaLayers

PHASES = ("approach", "hover", "advance", "withdraw", "hold", "retract", "settle")
APPROACH, HOVER, ADVANCE, WITHDRAW, HOLD, RETRACT, SETTLE = range(len(PHASES))


def depths(cfg: EpisodeSettings, layers: RetinaLayers) -> tuple[float, float]:
    """(deepest, hold) depths [m] below the predicted ILM: the hold at the target depth plus
    the overshoot; the advance to that depth, or to `puncture_depth_m` when the hold is
    shallower (the ILM gives way only past its tent; the withdraw phase then comes back)."""
    hold = layers.target_depth_m + cfg.overshoot_m
    return max(hold, cfg.puncture_depth_m), hold


def phase_durations(cfg: EpisodeSettings, layers: RetinaLayers) -> dict[str, float]:
    """Duration [s] of each phase, in order (the withdraw phase 0 s unless the target is
    shallower than the puncture depth). InvalidInputError if the puncture depth reaches the
    depth limit (the RPE less its margin)."""
    floor = layers.thickness_m - cfg.rpe_margin_m
    if cfg.puncture_depth_m >= floor:
        valid = (f"below the depth limit, {floor * 1e6:g} um (the {layers.thickness_m * 1e6:g} "
                 f"um retina less the {cfg.rpe_margin_m * 1e6:g} um RPE margin)")  # fmt: skip
        raise InvalidInputError("puncture_depth_m", cfg.puncture_depth_m, valid)
    deepest, hold = depths(cfg, layers)
    speed = cfg.advance_speed_m_s
    return {
        "approach": (cfg.start_height_m - cfg.standoff_m) / cfg.approach_speed_m_s,
        "hover": cfg.hover_s,
        "advance": (cfg.standoff_m + deepest) / speed,
        "withdraw": (deepest - hold) / speed,
        "hold": cfg.hold_s,
        "retract": (cfg.standoff_m + hold) / speed,
        "settle": cfg.settle_s,
    }


def phases_at(
    durations: dict[str, float], t_loop_s: FloatArray
) -> tuple[NDArray[np.int64], FloatArray]:
    """The phase (index in PHASES) at each loop time t_loop_s [s] and the fraction of it done;
    past the end, the settle phase done (1). A phase of zero length is never current."""
    lengths = np.array([durations[p] for p in PHASES], dtype=float)
    ends = np.cumsum(lengths)
    starts = np.concatenate(([0.0], ends[:-1]))
    phase = np.searchsorted(ends, t_loop_s, side="right")
    past = phase >= len(PHASES)
    phase[past] = SETTLE
    a = np.where(past, 1.0, (t_loop_s - starts[phase]) / np.where(past, 1.0, lengths[phase]))
    return phase, a


def commanded_depth(
    phase: NDArray[np.int64], a: FloatArray, cfg: EpisodeSettings, layers: RetinaLayers
) -> FloatArray:
    """Commanded depth [m] below the predicted ILM per period, in its phase (index in PHASES)
    at the fraction a in [0, 1] of it; NaN during the approach (a blend from the start point,
    `tip_radius`)."""
    top, (deep, target) = -cfg.standoff_m, depths(cfg, layers)
    # per phase: the depth at its start and at its end (a ramp between them; NaN: the approach)
    ends = ((np.nan, np.nan), (top, top), (top, deep), (deep, target), (target, target),
            (target, top), (top, top))  # fmt: skip
    out = np.empty(np.shape(phase))
    for i in np.unique(phase):  # a block of periods spans one or two phases
        here = phase == i
        start, end = ends[i]
        out[here] = start + a[here] * (end - start) if start != end else start
    return out


def tip_radius(
    phase: NDArray[np.int64], a: FloatArray, predicted_m: FloatArray, start_radius_m: float,
    cfg: EpisodeSettings, layers: RetinaLayers,
) -> tuple[FloatArray, FloatArray]:  # fmt: skip
    """Commanded radius of the tip [m] and depth below the predicted ILM [m] per period, from
    the predicted ILM displacement [m]; the approach blends from `start_radius_m` [m] to the
    stand-off."""
    ilm = layers.ilm_radius_m + predicted_m
    c = commanded_depth(phase, a, cfg, layers)
    blend = (1.0 - a) * start_radius_m + a * (ilm - cfg.standoff_m)
    approach = phase == APPROACH
    radius = np.where(approach, blend, ilm + c)
    return radius, np.where(approach, blend - ilm, c)
