"""Prediction of the ILM displacement across the iOCT latency: RMS error of every predictor
(none, hold, fft, kalman) at the default 9 Hz / 150 ms on estimates segmented from synthetic
B-scans, and on a grid of volume rates (1.6-51 Hz) and latencies (0-300 ms); the segmentation's
RMS error; ratios against hold and fft measured in the same run.

Run: python benchmarks/bench_subretinal_predict.py [--episodes N] [--image-episodes N]

Episode k: motion seed k (`MotionModel()` defaults), image or noise seed 10000 + k, 30 s, the
error sampled every 10 ms from 12 s on (every predictor past its start-up). The grid feeds the
predictors the true displacement plus the segmentation's error as measured on the images of
this run (its mean and standard deviation), since rendering every image at 51 Hz would take
hours; at 9 Hz both inputs are run and printed side by side.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

import numpy as np

from _common import quick, row
from rcmplan.subretinal.ioct import IoctModel
from rcmplan.subretinal.layers import RetinaLayers
from rcmplan.subretinal.motion import MotionModel, sample_motion
from rcmplan.subretinal.predictors import PREDICTORS
from rcmplan.subretinal.segment_error import rms_m
from rcmplan.subretinal.trace import (
    IlmTrace,
    NeedleHold,
    image_trace,
    noisy_trace,
    prediction_errors,
)

UM = 1e6
DURATION_S, WARMUP_S, STEP_S = 30.0, 12.0, 0.01
RATES_HZ = (1.6, 4.0, 9.0, 26.0, 51.0)
LATENCIES_S = (0.0, 0.05, 0.1, 0.15, 0.22, 0.3)
DEFAULT_LATENCY_S = 0.15
FFT_WINDOWS_S = (5.0, 7.0, 10.0, 15.0)


def squared_errors(traces: list[tuple[Any, IlmTrace]], latencies: tuple[float, ...],
                   name: str, **kwargs: Any) -> np.ndarray:  # fmt: skip
    """Mean squared error per episode and latency (episodes, latencies) [m^2]."""
    t_eval = np.arange(WARMUP_S, DURATION_S, STEP_S)
    out = [np.mean(prediction_errors(name, trace, latencies, traj, t_eval, **kwargs) ** 2, axis=1)
           for traj, trace in traces]  # fmt: skip
    return np.array(out)


def image_traces(n: int) -> tuple[list[tuple[Any, IlmTrace]], float]:
    """n episodes segmented from B-scans at the default rate, and the time per image [s]."""
    ioct, layers, needle = IoctModel(), RetinaLayers(), NeedleHold()
    out, start, images = [], time.perf_counter(), 0
    for k in range(n):
        traj = sample_motion(MotionModel(), DURATION_S, k)
        trace = image_trace(traj, ioct, layers, needle, np.random.default_rng(10_000 + k))
        out.append((traj, trace))
        images += len(trace.errors)
    return out, (time.perf_counter() - start) / images


def noisy_traces(n: int, rate_hz: float, std_m: float, bias_m: float) -> list:
    """n episodes of true displacement plus the measured segmentation error."""
    ioct = IoctModel(volume_rate_hz=rate_hz)
    out = []
    for k in range(n):
        traj = sample_motion(MotionModel(), DURATION_S, k)
        rng = np.random.default_rng(10_000 + k)
        out.append((traj, noisy_trace(traj, ioct, std_m, rng, bias_m=bias_m)))
    return out


def pooled_rms_um(mse: np.ndarray) -> np.ndarray:
    """RMS over episodes [um] per latency from per-episode mean squares."""
    return np.sqrt(mse.mean(axis=0)) * UM


def segmentation_rows(traces: list[tuple[Any, IlmTrace]], per_image_s: float) -> list[dict]:
    """The segmentation's errors over every image of the run."""
    errors = [e for _, trace in traces for e in trace.errors]
    px = IoctModel().axial_pixel_m
    offsets = np.array([e.ilm_offset_m for e in errors if e.ilm_offset_m is not None])
    rows = [row(f"segmentation {name} RMS ({len(errors)} B-scans)", rms_m(values) * UM, "um",
                "axial pixel", px * UM)
            for name, values in (
                ("ILM per A-line", [e.ilm_rms_m for e in errors]),
                ("RPE per A-line", [e.rpe_rms_m for e in errors]),
                ("ILM offset (motion estimate)", [e.ilm_offset_m for e in errors]),
                ("needle tip", [e.tip_m for e in errors]),
            )]  # fmt: skip
    rows.append(row("segmentation ILM offset bias (mean error)", offsets.mean() * UM, "um"))
    rows.append(row("segmentation ILM offset standard deviation", offsets.std() * UM, "um"))
    rows.append(row("render + segment one B-scan", per_image_s * 1e3, "ms"))
    return rows


def default_rows(label: str, rms_um: dict[str, float], worst_um: dict[str, float]) -> list:
    """RMS per predictor at the default rate and latency, with ratios to hold and fft."""
    out = []
    for name in PREDICTORS:
        for peer in ("hold", "fft"):
            if name != peer and not (name == "none" and peer == "fft"):
                out.append(row(f"{name} RMS error, 9 Hz, 150 ms, {label}", rms_um[name], "um",
                               peer, rms_um[peer]))  # fmt: skip
        out.append(row(f"{name} worst episode RMS, {label}", worst_um[name], "um"))
    return out


def at_default(traces: list) -> tuple[dict[str, float], dict[str, float]]:
    """Pooled and worst-episode RMS [um] per predictor at 150 ms."""
    pooled, worst = {}, {}
    for name in PREDICTORS:
        mse = squared_errors(traces, (DEFAULT_LATENCY_S,), name)[:, 0]
        pooled[name], worst[name] = float(np.sqrt(mse.mean()) * UM), float(np.sqrt(mse.max()) * UM)
    return pooled, worst


def grid(n: int, std_m: float, bias_m: float) -> dict[str, np.ndarray]:
    """RMS [um] per predictor over (rates, latencies)."""
    out = {name: np.zeros((len(RATES_HZ), len(LATENCIES_S))) for name in PREDICTORS}
    for i, rate in enumerate(RATES_HZ):
        traces = noisy_traces(n, rate, std_m, bias_m)
        for name in PREDICTORS:
            out[name][i] = pooled_rms_um(squared_errors(traces, LATENCIES_S, name))
    return out


def print_grid(title: str, table: np.ndarray, fmt: str = "{:8.2f}") -> None:
    print(f"\n{title}")
    print("rate Hz \\ latency ms" + "".join(f"{1e3 * lat:8.0f}" for lat in LATENCIES_S))
    for rate, values in zip(RATES_HZ, table, strict=True):
        print(f"{rate:20.1f}" + "".join(fmt.format(v) for v in values))


def run(episodes: int, image_episodes: int) -> tuple[list[dict], dict[str, Any]]:
    """Every figure: the rows, and the grid and FFT-window sweep for printing."""
    images, per_image_s = image_traces(image_episodes)
    offsets = np.array([e.ilm_offset_m for _, t in images for e in t.errors
                        if e.ilm_offset_m is not None])  # fmt: skip
    bias, std = float(offsets.mean()), float(offsets.std())
    rows = segmentation_rows(images, per_image_s)
    pooled, worst = at_default(images)
    rows += default_rows(f"segmented B-scans, {image_episodes} episodes", pooled, worst)
    noisy = noisy_traces(episodes, 9.0, std, bias)
    pooled_n, worst_n = at_default(noisy)
    rows += default_rows(f"measured segmentation noise, {episodes} episodes", pooled_n, worst_n)
    sweep = {w: float(pooled_rms_um(squared_errors(noisy, (DEFAULT_LATENCY_S,), "fft",
                                                   window_s=w))[0])
             for w in FFT_WINDOWS_S}  # fmt: skip
    return rows, {"grid": grid(episodes, std, bias), "fft_windows": sweep}


def rows() -> list[dict]:
    """The benchmark's rows for run.py: 50 episodes (10 with --quick); the figures of
    docs/subretinal.md come from `main` with 200 (about 25 min on 2 shared cores)."""
    n = 10 if quick() else 50
    return run(n, n)[0]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=10 if quick() else 200)
    ap.add_argument("--image-episodes", type=int, default=10 if quick() else 200)
    args = ap.parse_args(argv)
    from run import print_table

    start = time.perf_counter()
    table, extra = run(args.episodes, args.image_episodes)
    print_table(table)
    g = extra["grid"]
    for name in PREDICTORS:
        print_grid(f"{name}: RMS error [um], measured segmentation noise", g[name])
    for peer in ("hold", "fft"):
        print_grid(f"kalman / {peer}", g["kalman"] / g[peer], "{:8.3f}")
    print("\nfft window [s] -> RMS error [um] at 9 Hz, 150 ms:",
          ", ".join(f"{w:g}: {v:.2f}" for w, v in extra["fft_windows"].items()))  # fmt: skip
    print(f"\n{time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
