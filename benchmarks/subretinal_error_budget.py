"""Where the depth error of a subretinal episode's hold comes from, for episodes of a batch.

Run: python benchmarks/subretinal_error_budget.py --seed 0 --episodes 42 50 76 [--method kalman]
[--heart-rate-sd-bpm SD]. Episode k of a seed is the batch's episode k (`episode_draws`, default
ranges), run alone. Prints one JSON object per episode, then the RMS of each part pooled over
the episodes that failed and over those that succeeded (in band for the whole hold, status ok).

Over the hold, the tip's depth below the true ILM less the target depth splits exactly into:

- `cardiac`: the prediction's cardiac part less the true cardiac displacement (the whole
  cardiac motion, negated, where the filter leaves it out);
- `breathing_estimate`: the filter's breathing and offset at the newest estimate's acquisition
  less the true breathing there (the estimates' noise and bias, and what the filter absorbed of
  motion it does not model);
- `breathing_extrapolation`: how the breathing and offset change from that acquisition to the
  period, predicted less true (across the latency and between volumes);
- `tracking`: the tip's radius less the commanded one (the robot's lag behind a target that
  jumps when an estimate arrives: the QP's speed limits);
- `tissue`: the depth in tissue less the tip's depth below the undisplaced-by-tenting ILM (the
  ILM still tented, punctured late);
- `command`: the commanded depth less the target depth (0 in the hold).

The predictor is replayed on the episode's own estimates with their arrival times, and its
predictions are checked against the episode's `predicted_m` series (1e-12 m).
"""

from __future__ import annotations

import argparse
import json
from typing import Any

import numpy as np

from rcmplan.subretinal.episode import Episode
from rcmplan.subretinal.episode_draws import DrawRanges, draw_episode
from rcmplan.subretinal.episode_metrics import summarise
from rcmplan.subretinal.episode_phases import PHASES
from rcmplan.subretinal.episode_settings import EpisodeSettings
from rcmplan.subretinal.motion import MotionModel
from rcmplan.subretinal.predictors import make_predictor

PARTS = ("cardiac", "breathing_estimate", "breathing_extrapolation", "tracking", "tissue",
         "command")  # fmt: skip


def components(model: Any, t: np.ndarray) -> np.ndarray:
    """(breathing, cardiac, offset) predicted at t [s], (n, 3) [m]; for a Kalman filter
    without `components` (before its folded bands: one rate per harmonic), from its state."""
    if hasattr(model, "components"):
        return np.asarray(model.components(t))
    x, dt = model.x, t - model.t_last_s
    parts = [x[2 * k] * np.cos(x[5 + k] * dt) - x[2 * k + 1] * np.sin(x[5 + k] * dt)
             for k in range(2)]  # fmt: skip
    return np.stack([*parts, np.full(t.shape, x[4])], axis=-1)


def replay(ep: Episode, model: Any, t: np.ndarray) -> tuple[np.ndarray, ...]:
    """The predictor's parts at the periods t [s] as the episode asked for them (n, 3) [m],
    the acquisition time [s] of the newest estimate each period had, and the filter's breathing
    plus offset at that acquisition [m]."""
    arrival = ep.trace.t_acq_s + ep.cfg.latency_s
    got = np.searchsorted(arrival, t, side="right")
    parts, t_newest, at_newest = np.zeros((t.size, 3)), np.zeros(t.size), np.zeros(t.size)
    for n in range(1, ep.trace.t_acq_s.size + 1):
        t_acq = float(ep.trace.t_acq_s[n - 1])
        model.update(t_acq, float(ep.trace.estimate_m[n - 1]))
        now = got == n
        if now.any():
            parts[now] = components(model, t[now])
            at = components(model, np.array([t_acq]))[0]
            t_newest[now], at_newest[now] = t_acq, at[0] + at[2]
    return parts, t_newest, at_newest


def predictor_inputs(cfg: EpisodeSettings) -> dict[str, Any]:
    """The heart-rate reading the episode gives its predictor, if any (imported only then, so
    that the script also runs on the source before `monitor.py`)."""
    if getattr(cfg, "heart_rate_sd_hz", None) is None:
        return {}
    from rcmplan.subretinal.monitor import heart_rate_input

    return heart_rate_input(cfg, motion_model(cfg))


def motion_model(cfg: EpisodeSettings) -> MotionModel:
    """The episode's motion model, as `Episode` builds it."""
    return MotionModel(
        breathing_amplitude_m=cfg.breathing_m,
        breathing_rate_hz=cfg.breathing_rate_hz,
        cardiac_amplitude_m=cfg.cardiac_m,
        cardiac_rate_hz=cfg.cardiac_rate_hz,
    )


def budget(seed: int, episode: int, method: str, heart_rate_sd_hz: float | None) -> dict[str, Any]:
    """The hold's error parts of one episode (module docstring), RMS and mean in [um]."""
    draw = draw_episode(DrawRanges(), seed, episode)
    base = (
        EpisodeSettings()
        if heart_rate_sd_hz is None
        else EpisodeSettings(heart_rate_sd_hz=heart_rate_sd_hz)
    )
    cfg = draw.settings(base, method)
    ep = Episode(cfg)
    result = ep.run()
    doc, s = summarise(result), result.series
    hold = s["phase"].astype(int) == PHASES.index("hold")
    t = s["t_s"][hold]
    wall, pred, cmd = s["wall_m"][hold], s["predicted_m"][hold], s["command_depth_m"][hold]
    z, depth = s["depth_vs_undeformed_m"][hold], s["depth_m"][hold]
    model = make_predictor(method, **predictor_inputs(cfg))
    parts, t_newest, est_newest = replay(ep, model, t)
    if not np.allclose(parts.sum(axis=1), pred, rtol=0.0, atol=1e-12):
        raise RuntimeError("the replayed predictor does not give the episode's predictions")
    true = ep.motion.components(t)
    breath_newest = ep.motion.components(t_newest)[:, 0]
    split = {
        "cardiac": parts[:, 1] - true[:, 1],
        "breathing_estimate": est_newest - breath_newest,
        "breathing_extrapolation": (parts[:, 0] + parts[:, 2] - est_newest)
        - (true[:, 0] - breath_newest),
        "tracking": z + wall - pred - cmd,
        "tissue": depth - z,
        "command": cmd - ep.layers.target_depth_m,
    }
    error = depth - ep.layers.target_depth_m
    if not np.allclose(sum(split.values()), error, rtol=0.0, atol=1e-9):
        raise RuntimeError("the parts do not add up to the depth error")
    worst = int(np.argmax(np.abs(error)))
    um = 1e6
    source = getattr(cfg, "ioct_estimates", "noise")  # the source before image estimates: noise
    return {
        "episode": episode, "ioct_rate_hz": cfg.ioct_rate_hz, "heart_rate_hz": cfg.cardiac_rate_hz,
        "cardiac_um": cfg.cardiac_m * um, "breathing_um": cfg.breathing_m * um,
        "latency_s": cfg.latency_s, "ioct_estimates": source,
        "noise_um": cfg.noise_std_m * um if source == "noise" else None,
        "success": doc["status"] == "ok" and doc["in_band_fraction"] == 1.0,
        "in_band_fraction": doc["in_band_fraction"],
        "error_rms_um": float(np.sqrt(np.mean(error**2))) * um,
        "error_max_um": float(np.abs(error).max()) * um,
        "rms_um": {k: float(np.sqrt(np.mean(v**2))) * um for k, v in split.items()},
        "mean_um": {k: float(np.mean(v)) * um for k, v in split.items()},
        "at_worst_um": {k: float(v[worst]) * um for k, v in split.items()},
    }  # fmt: skip


def pooled(rows: list[dict[str, Any]]) -> dict[str, float]:
    """RMS of each part [um] pooled over episodes (each weighed by its hold, all equal)."""
    keys = [*PARTS]
    out = {k: float(np.sqrt(np.mean([r["rms_um"][k] ** 2 for r in rows]))) for k in keys}
    out["total"] = float(np.sqrt(np.mean([r["error_rms_um"] ** 2 for r in rows])))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--episodes", type=int, nargs="+", required=True)
    ap.add_argument("--method", default="kalman")
    ap.add_argument("--heart-rate-sd-bpm", type=float, default=None)
    args = ap.parse_args()
    sd = None if args.heart_rate_sd_bpm is None else args.heart_rate_sd_bpm / 60.0
    rows = []
    for k in args.episodes:
        rows.append(budget(args.seed, k, args.method, sd))
        print(json.dumps(rows[-1]), flush=True)
    for name, ok in (("failed", False), ("succeeded", True)):
        chosen = [r for r in rows if r["success"] is ok]
        if chosen:
            print(json.dumps({"pooled": name, "episodes": len(chosen), "rms_um": pooled(chosen)}))


if __name__ == "__main__":
    main()
