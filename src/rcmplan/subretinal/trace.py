"""One episode's iOCT estimates of the ILM displacement, and the error of a predictor across
the latency.

`image_trace` renders a B-scan at every acquisition of a motion trajectory (the needle held
still above the retina by the robot, the eye moving under it) and segments it: the estimates
a controller would receive, each `latency_s` after its acquisition. `noisy_trace` stands in for
it where rendering every image costs too much: the true displacement plus Gaussian noise of a
given standard deviation (what `image_trace` measured). `prediction_errors` feeds a predictor
the estimates as they arrive and compares its prediction with the true displacement on a grid
of times (the controller's "now"), for several latencies at once.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from rcmplan._validate import FloatArray, scalar
from rcmplan.exceptions import InvalidInputError
from rcmplan.subretinal.ioct import BScanScene, IoctModel, render_bscan
from rcmplan.subretinal.layers import RetinaLayers
from rcmplan.subretinal.motion import MotionTrajectory
from rcmplan.subretinal.predictors import make_predictor
from rcmplan.subretinal.segment import segment_bscan
from rcmplan.subretinal.segment_error import SegmentationError, segmentation_error

POLE = (0.0, 0.0, 1.0)  # the B-scan's depth axis, at the posterior pole (x: the eye frame's x)


@dataclass(frozen=True)
class NeedleHold:
    """Where the robot holds the needle during an episode, in the B-scan frame (room-fixed).

    Attributes:
        tip_x_m: Lateral tip position [m].
        height_m: Height of the tip above the undisplaced ILM [m].
        tilt_rad: Needle angle from the depth axis [rad] (`BScanScene.needle_tilt_rad`).
        diameter_m: Cannula outer diameter [m].
    """

    tip_x_m: float = -150e-6
    height_m: float = 150e-6
    tilt_rad: float = 0.5
    diameter_m: float = 100e-6

    def __post_init__(self) -> None:
        scalar("height_m", self.height_m, -1e-3, 1e-3)


@dataclass(frozen=True)
class IlmTrace:
    """The estimates of one episode.

    Attributes:
        t_acq_s: Acquisition times (K,) [s] of the estimates.
        estimate_m: Estimated ILM displacement (K,) [m].
        truth_m: True ILM displacement at each acquisition (K,) [m].
        errors: Segmentation errors per acquisition (empty for a `noisy_trace`).
        dropped: Acquisitions whose segmentation found no ILM (left out of the estimates).
    """

    t_acq_s: FloatArray
    estimate_m: FloatArray
    truth_m: FloatArray
    errors: tuple[SegmentationError, ...] = ()
    dropped: int = 0


def image_trace(
    trajectory: MotionTrajectory,
    ioct: IoctModel,
    layers: RetinaLayers,
    needle: NeedleHold,
    rng: np.random.Generator,
) -> IlmTrace:
    """Render and segment a B-scan at every acquisition over the trajectory."""
    times, estimates, truths, errors, dropped = [], [], [], [], 0
    for t in ioct.acquisition_times(trajectory.duration_s):
        scene = BScanScene(
            ilm_offset_m=float(trajectory.ilm_offset(t, POLE)),
            lateral_shift_m=float(trajectory.translation(t)[0]),
            curvature_radius_m=layers.ilm_radius_m,
            thickness_m=layers.thickness_m,
            choroid_m=layers.choroid_m,
            tip_m=(needle.tip_x_m, -needle.height_m),
            needle_tilt_rad=needle.tilt_rad,
            needle_diameter_m=needle.diameter_m,
        )
        seg = segment_bscan(render_bscan(ioct, scene, rng), ioct, layers.ilm_radius_m,
                            needle.diameter_m)  # fmt: skip
        errors.append(segmentation_error(seg, scene, ioct))
        if seg.ilm_offset_m is None:
            dropped += 1
            continue
        times.append(t)
        estimates.append(seg.ilm_offset_m)
        truths.append(scene.ilm_offset_m)
    return IlmTrace(np.array(times), np.array(estimates), np.array(truths), tuple(errors), dropped)


def noisy_trace(
    trajectory: MotionTrajectory,
    ioct: IoctModel,
    noise_std_m: float,
    rng: np.random.Generator,
    bias_m: float = 0.0,
) -> IlmTrace:
    """The true ILM displacement at every acquisition plus `bias_m` and N(0, noise_std_m^2)
    [m]: a stand-in for `image_trace` with the error it measured."""
    std = scalar("noise_std_m", noise_std_m, 0.0, 1e-3)
    bias = scalar("bias_m", bias_m, -1e-3, 1e-3)
    t = ioct.acquisition_times(trajectory.duration_s)
    truth = trajectory.ilm_offset(t, POLE)
    return IlmTrace(t, truth + bias + std * rng.standard_normal(t.shape), truth)


def prediction_errors(
    predictor: str,
    trace: IlmTrace,
    latencies_s: Sequence[float],
    trajectory: MotionTrajectory,
    t_eval_s: FloatArray,
    **kwargs: Any,
) -> FloatArray:
    """Prediction less truth [m], (len(latencies_s), len(t_eval_s)), for a predictor by name
    given each estimate of `trace` a latency after its acquisition, at the sorted times
    `t_eval_s`. One predictor serves every latency: its state after n estimates does not depend
    on when they arrived, only which of its predictions are asked for does."""
    lats = [scalar("latency_s", lat, 0.0, 5.0) for lat in latencies_s]
    t_eval = np.asarray(t_eval_s, dtype=np.float64)
    if t_eval.ndim != 1 or np.any(np.diff(t_eval) < 0):
        raise InvalidInputError("t_eval_s", t_eval_s, "a sorted 1-D array of times [s]")
    model = make_predictor(predictor, **kwargs)
    arrived = [np.searchsorted(trace.t_acq_s + lat, t_eval, side="right") for lat in lats]
    out = np.empty((len(lats), t_eval.size))
    for n in range(trace.t_acq_s.size + 1):
        if n > 0:
            model.update(float(trace.t_acq_s[n - 1]), float(trace.estimate_m[n - 1]))
        for i, got in enumerate(arrived):
            a, b = np.searchsorted(got, n, side="left"), np.searchsorted(got, n, side="right")
            if b > a:
                out[i, a:b] = model.predict(t_eval[a:b])
    return out - trajectory.ilm_offset(t_eval, POLE)[None, :]


def rms(values: FloatArray, axis: int | None = None) -> FloatArray:
    """Root mean square of an array (over `axis`, or all of it) [same unit]."""
    return np.sqrt(np.mean(np.square(values), axis=axis))
