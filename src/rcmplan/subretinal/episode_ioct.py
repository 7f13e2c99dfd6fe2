"""What an episode's controller sees of the retina: the iOCT volumes, acquired from the episode's
true state, segmented, and delivered late.

Volumes are acquired at t_acq = k / rate (k = 0, 1, ...: from the start of the warm-up) and
delivered at t_acq + latency. Each is the B-scan through the needle (`ioct` module docstring),
its scene built from the episode's true state at t_acq (`acquisition_scene`): the ILM
displaced by the wall motion d(t_acq) relative to the eye, the tip and the needle's axis where
the robot actually held them (the period at or before t_acq), relative to the eye's centre
where the eye was then, and the ILM tented under the tip as the tissue model had it. B-scan x
is the eye frame's x across the target's normal, z the depth along the normal; the needle lies
in the scan plane (its tilt out of the plane is ignored; a needle steeper than 0.1 rad from the
normal is drawn at 0.1 rad, the renderer's range).

Two sources of the estimate (`EpisodeSettings.ioct_estimates`):

- "image": the B-scan is rendered (`ioct.render_bscan`, speckle from the generator of
  `SeedSequence(seed, spawn_key=(SPECKLE_KEY, k))`) and segmented from the image alone
  (`segment.segment_bscan`); the estimate is the segmented ILM offset, and a volume whose
  segmentation finds no ILM delivers nothing (dropped). Its error against the scene is
  measured (`segment_error.segmentation_error`) for every volume delivered.
- "noise": the measured-noise stand-in, `trace.noisy_trace` (true displacement plus the bias
  and standard deviation that the images gave with the needle above the retina, drawn up front
  from the episode's generator): no image is rendered, the scenes are still kept.

`EpisodeIoct.acquire` is called when a volume is delivered (its state is then in the past); the
acquisitions delivered are kept in order (`received`) for the summary and the replay's B-scans,
which re-render the same scenes with the same speckle (`episode_bscans`).
"""

from __future__ import annotations

import copy
import math
from typing import Any, NamedTuple, Protocol

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.exceptions import InvalidInputError
from rcmplan.scene.eye import Eye, eye_frame
from rcmplan.subretinal.episode_settings import SEGMENTATION_BIAS_M, EpisodeSettings
from rcmplan.subretinal.ioct import BScanScene, IoctModel, render_bscan
from rcmplan.subretinal.layers import RetinaLayers, unit_direction
from rcmplan.subretinal.motion import MotionTrajectory
from rcmplan.subretinal.segment import Segmentation, segment_bscan
from rcmplan.subretinal.segment_error import SegmentationError, segmentation_error
from rcmplan.subretinal.tissue import TissueContact
from rcmplan.subretinal.trace import IlmTrace, NeedleHold, noisy_trace

MIN_TILT_RAD, MAX_TILT_RAD = 0.1, 1.4  # what BScanScene draws
SPECKLE_KEY = 2  # spawn key of the speckle generators (1: the eye's translation, `Episode`)


class TrueState(NamedTuple):
    """The episode's true state at an acquisition (robot base frame, SI units).

    Attributes:
        tip_m: Needle tip (3,) [m].
        base_m: Needle base (3,) [m] (the axis runs from it to the tip).
        center_m: The eye's centre (3,) [m], where the eye was.
        tent_m: The ILM's tenting under the tip [m] (0 unless the tissue model tents it).
    """

    tip_m: FloatArray
    base_m: FloatArray
    center_m: FloatArray
    tent_m: float


class Received(NamedTuple):
    """One volume delivered to the controller.

    Attributes:
        number: Its acquisition number k (t_acq = k / rate).
        t_acq_s: Acquisition time [s] (episode time).
        scene: The truth it was acquired from (`acquisition_scene`).
        estimate_m: The ILM displacement delivered [m]; None: dropped (no ILM segmented).
        error: The segmentation's error against the scene ("image" estimates; None for the
            stand-in).
        tip_in_window: Whether the true tip lay inside the B-scan's window.
    """

    number: int
    t_acq_s: float
    scene: BScanScene
    estimate_m: float | None
    error: SegmentationError | None
    tip_in_window: bool


class EpisodeState(Protocol):
    """What `true_state` reads of an episode (`subretinal.episode.Episode`): per period run
    (the first `done`) its tip, base and tent and the eye's centre; the start pose."""

    t_s: FloatArray
    done: int
    tip_m: FloatArray
    base_m: FloatArray
    tent_m: FloatArray
    center_m: FloatArray
    start_tip: FloatArray
    start_base: FloatArray
    eye: Eye
    motion: MotionTrajectory
    layers: RetinaLayers
    tissue: TissueContact

    def needle_now(self) -> tuple[FloatArray, FloatArray]: ...
    def depth_of(self, tip_m: FloatArray, k: Any) -> FloatArray: ...


def true_state(ep: EpisodeState, t_s: float) -> TrueState:
    """The episode's true state at time t_s [s], at most the time of its next period to run:
    that of the period at or before it, read at the period's start (the plant moves at its
    end; the next period's from the plant now, its tissue as it would read); before the first
    period (the warm-up) the needle at its start point relative to the eye (which carries the
    trocar), the eye where it was then, the tissue as the start tip leaves it."""
    i = int(np.searchsorted(ep.t_s, t_s, side="right")) - 1
    if i < 0:
        center = ep.eye.center + ep.motion.translation(t_s)
        shift = center - ep.center_m[0]
        z = float(np.linalg.norm(ep.start_tip - ep.center_m[0])) - (
            ep.layers.ilm_radius_m + float(ep.motion.displacement(t_s))
        )
        tent = TissueContact(ep.tissue.model).update(z).tent_m
        return TrueState(ep.start_tip + shift, ep.start_base + shift, center, tent)
    if i < ep.done:
        return TrueState(ep.tip_m[i], ep.base_m[i], ep.center_m[i], float(ep.tent_m[i]))
    if i > ep.done:
        valid = f"at most {ep.t_s[ep.done]:g} s, the next period to run"
        raise InvalidInputError("t_s", t_s, valid)
    tip, base = ep.needle_now()
    tent = copy.copy(ep.tissue).update(float(ep.depth_of(tip, i))).tent_m
    return TrueState(tip, base, ep.center_m[i], tent)


def bscan_axes(eye: Eye, direction: object) -> tuple[FloatArray, FloatArray]:
    """The target's normal and the B-scan's lateral axis (3,) each, robot base frame, of an
    episode's eye and target direction (as `Episode` places them)."""
    R = eye_frame(eye)
    normal = R @ unit_direction(direction)
    lateral = R[:, 0] - np.dot(R[:, 0], normal) * normal
    return normal, lateral / np.linalg.norm(lateral)


def acquisition_scene(
    layers: RetinaLayers, offset_m: float, state: TrueState, axes: tuple[FloatArray, FloatArray]
) -> BScanScene:
    """The B-scan scene of one acquisition (module docstring): the ILM displaced by `offset_m`
    [m], the needle and the tent of `state`, in the frame of `axes` (`bscan_axes`)."""
    normal, lateral = axes
    tip = state.tip_m - state.center_m
    x, z = float(tip @ lateral), float(tip @ normal) - layers.ilm_radius_m
    axis = state.tip_m - state.base_m
    tilt = math.atan2(float(axis @ lateral), float(axis @ normal))
    tilt = math.copysign(min(max(abs(tilt), MIN_TILT_RAD), MAX_TILT_RAD), tilt)
    return BScanScene(
        ilm_offset_m=offset_m, curvature_radius_m=layers.ilm_radius_m,
        thickness_m=layers.thickness_m, choroid_m=layers.choroid_m, tent_m=state.tent_m,
        tent_x_m=x, tip_m=(x, z), needle_tilt_rad=tilt, needle_diameter_m=NeedleHold().diameter_m,
    )  # fmt: skip


def speckle_rng(seed: int, index: int) -> np.random.Generator:
    """The speckle generator of acquisition `index` of an episode with seed `seed`."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(SPECKLE_KEY, index)))


def segment_acquisition(
    model: IoctModel, scene: BScanScene, seed: int, index: int
) -> tuple[FloatArray, Segmentation]:
    """Render acquisition `index`'s B-scan (dB) and segment it from the image alone."""
    image = render_bscan(model, scene, speckle_rng(seed, index))
    seg = segment_bscan(image, model, scene.curvature_radius_m, scene.needle_diameter_m)
    return image, seg


class EpisodeIoct:
    """The iOCT of one episode (module docstring)."""

    def __init__(
        self,
        cfg: EpisodeSettings,
        layers: RetinaLayers,
        eye: Eye,
        motion: MotionTrajectory,
        rng: np.random.Generator,
    ) -> None:
        """`motion`: the wall's motion relative to the eye (no whole-eye translation);
        `rng`: the episode's generator, from which the stand-in draws its noise."""
        self.cfg, self.layers = cfg, layers
        self.model = IoctModel(volume_rate_hz=cfg.ioct_rate_hz, latency_s=cfg.latency_s)
        self.stand_in: IlmTrace | None = None
        if cfg.ioct_estimates == "noise":
            self.stand_in = noisy_trace(motion, self.model, cfg.noise_std_m, rng,
                                        SEGMENTATION_BIAS_M)  # fmt: skip
            self.t_acq_s = self.stand_in.t_acq_s
        else:
            self.t_acq_s = self.model.acquisition_times(motion.duration_s)
        self.arrival_s: FloatArray = self.t_acq_s + cfg.latency_s
        self.truth_m: FloatArray = motion.displacement(self.t_acq_s)
        self.axes = bscan_axes(eye, cfg.direction)
        self.received: list[Received] = []

    def acquire(self, k: int, state: TrueState) -> float | None:
        """Acquisition k from the true state at its time: the estimate it delivers [m], or
        None (dropped: no ILM segmented)."""
        scene = acquisition_scene(self.layers, float(self.truth_m[k]), state, self.axes)
        error = None
        if self.stand_in is None:
            _, seg = segment_acquisition(self.model, scene, self.cfg.seed, k)
            estimate, error = seg.ilm_offset_m, segmentation_error(seg, scene, self.model)
        else:
            estimate = float(self.stand_in.estimate_m[k])
        z = self.model.depth_axis_m()
        half = 0.5 * self.model.axial_pixel_m
        inside = scene.tip_m is not None and bool(z[0] - half <= scene.tip_m[1] <= z[-1] + half)
        self.received.append(Received(k, float(self.t_acq_s[k]), scene, estimate, error, inside))
        return estimate

    def trace(self) -> IlmTrace:
        """The estimates delivered (dropped ones left out), their truths, every delivered
        volume's segmentation error ("image"), and how many were dropped."""
        got = [r for r in self.received if r.estimate_m is not None]
        errors = tuple(r.error for r in self.received if r.error is not None)
        return IlmTrace(
            t_acq_s=np.array([r.t_acq_s for r in got]),
            estimate_m=np.array([r.estimate_m for r in got], dtype=np.float64),
            truth_m=np.array([r.scene.ilm_offset_m for r in got]),
            errors=errors,
            dropped=len(self.received) - len(got),
        )
