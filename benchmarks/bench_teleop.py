"""Teleoperation on the synthetic surgeon (100 um RMS tremor, scale 20, the default 20 s
session that pushes past the retina margin once): tremor at the tip, added lag, tracking, RCM,
fixtures, and the time the pipeline adds to each 1 kHz period.

Run: python benchmarks/bench_teleop.py [--no-mujoco]

Peers measured in the same run: the same session with no filter (scaling alone) and with the
low-pass filter; the control step (QP step and plant period) the pipeline adds to, compiled
(where numba and DAQP's C binding serve) beside the reference Python QP step; the WFLC's
published reduction (67 % of the 6-16 Hz RMS on recorded hands, Riviere et al. 1998, quoted).
"""

from __future__ import annotations

import statistics
import sys
import time
from typing import Any
from unittest import mock

import numpy as np

from _common import per_call, quick, row
from rcmplan.teleop import SyntheticSurgeon, TeleopSettings, run_replay
from rcmplan.teleop.run import TeleopResult
from rcmplan.teleop.samples import MasterSample
from rcmplan.teleop.summary import summary

UM, MS = 1e6, 1e3
PUBLISHED_WFLC_REDUCTION = 0.67  # Riviere, Rader and Thakor 1998, 25 recorded trials


def session(filter_name: str, plant: str = "kinematic") -> tuple[TeleopResult, dict[str, Any]]:
    """The default synthetic session with one filter on one plant, and its summary."""
    settings = TeleopSettings(plant=plant, filter=filter_name, scale=20.0)
    result = run_replay(settings, SyntheticSurgeon(tremor_rms=100e-6).track())
    return result, summary(result)


def pipeline_cost(result: TeleopResult) -> tuple[float, float]:
    """(pipeline, control step) time per period [s]: the pipeline (filter, clutch, scaling,
    target) called in a tight loop on the session's own objects, and the median of the
    session's measured control steps (QP step, actuator command and plant period)."""
    s = result.session
    tip = tuple(float(v) for v in result.log.tip[-1])
    master = result.trace.master
    samples = [MasterSample(0.0, master[k], True) for k in range(0, len(master), 7)][:1000]
    k = [0]

    def one() -> None:
        smp = samples[k[0] % len(samples)]
        k[0] += 1
        s.targets.target(s.pipeline.step(0.0, smp, tip))  # type: ignore[arg-type]

    n = 2000 if quick() else 20000
    return per_call(one, n), float(statistics.median(result.trace.control_s))


def reference_control(compiled: dict[str, Any]) -> float:
    """The control step's median [s] of the same wflc session with the reference Python QP
    step (`QpSolver.step`: the session's compiled period step withheld), checked to give the
    same figures as the compiled run."""
    with mock.patch("rcmplan.servo.fast_period_step", lambda solver: None):
        result, s = session("wflc")
    if result.session.fast_step is not None:
        raise RuntimeError("the reference session took the compiled QP step")
    for key in ("max_rcm_deviation_m", "tip_tremor_rms_m", "tracking_rms_m"):
        if not np.isclose(s[key], compiled[key], rtol=1e-9, atol=1e-15):
            raise RuntimeError(f"{key}: reference {s[key]} against compiled {compiled[key]}")
    return float(statistics.median(result.trace.control_s))


def rows() -> list[dict[str, Any]]:
    """Every figure of the teleoperation benchmark."""
    mujoco = "--no-mujoco" not in sys.argv and not quick()
    start = time.perf_counter()
    wflc, w = session("wflc")
    _, lp = session("lowpass")
    _, none = session("none")
    out = [
        row("tip tremor RMS 6-16 Hz, wflc (kinematic)", w["tip_tremor_rms_m"] * UM, "um",
            "scaling alone (filter none)", none["tip_tremor_rms_m"] * UM, "<= 0.5 um"),
        row("tip tremor RMS 6-16 Hz, lowpass 2 Hz", lp["tip_tremor_rms_m"] * UM, "um",
            "scaling alone (filter none)", none["tip_tremor_rms_m"] * UM),
        row("input tremor RMS 6-16 Hz, scaled", w["input_tremor_rms_m"] * UM, "um"),
        row("tremor removed by wflc (fraction of 6-16 Hz RMS)", w["tremor_reduction"], "",
            "WFLC on recorded hands (quoted)", PUBLISHED_WFLC_REDUCTION),
        row("added lag of intended motion, wflc", w["added_lag_s"] * MS, "ms",
            "lowpass 2 Hz", lp["added_lag_s"] * MS, "<= 20 ms"),
        row("lowpass stated lag (group delay at 0 Hz)", lp["filter_delay_s"] * MS, "ms"),
        row("tracking RMS in free space, wflc", w["tracking_rms_m"] * UM, "um",
            "lowpass 2 Hz", lp["tracking_rms_m"] * UM, "<= 10 um"),
        row("max RCM deviation, kinematic", w["max_rcm_deviation_m"] * UM, "um", "", None,
            "<= 1 um"),
        row("limit violations, kinematic (periods)", sum(w["limit_violations"].values()), "",
            "", None, "0"),
        row("closest approach to the retina less the margin, kinematic",
            (w["retina_min_distance_m"] - w["retina_margin_m"]) * UM, "um", "", None, ">= 0"),
        row("time the desired tip lay past the retina margin", w["fixture_active_s"]["retina"],
            "s", "", None, "> 0 (the input pushes through)"),
    ]  # fmt: skip
    pipe, control = pipeline_cost(wflc)
    path = "compiled QP step" if wflc.session.fast_step is not None else "reference Python QP"
    reference = reference_control(w)
    out += [
        row("pipeline per 1 kHz period (wflc, tight loop)", pipe * UM, "us",
            f"control step (QP + plant), median, {path}", control * UM, "<= 20 us"),
        row("pipeline per period inside the session, median",
            w["pipeline_time_us"]["median"], "us", "", None, "<= 20 us"),
        row(f"control step (QP step, command, plant period), median, {path}", control * UM,
            "us", "the same session, reference Python QP step", reference * UM, "< 1,000 us"),
    ]  # fmt: skip
    if mujoco:
        _, m = session("wflc", "mujoco")
        out += [
            row("max RCM deviation, MuJoCo (dynamic)", m["max_rcm_deviation_m"] * UM, "um",
                "kinematic plant", w["max_rcm_deviation_m"] * UM, "<= 2 um"),
            row("tip tremor RMS 6-16 Hz, wflc, MuJoCo", m["tip_tremor_rms_m"] * UM, "um"),
            row("limit violations, MuJoCo (periods)", str(m["limit_violations"]), "", "", None,
                "0"),
            row("closest approach to the retina less the margin, MuJoCo",
                (m["retina_min_distance_m"] - m["retina_margin_m"]) * UM, "um", "", None,
                ">= 0"),
        ]  # fmt: skip
    out.append(row("benchmark wall time", time.perf_counter() - start, "s"))
    return out


if __name__ == "__main__":
    from run import print_table

    np.set_printoptions(precision=4)
    print_table(rows())
