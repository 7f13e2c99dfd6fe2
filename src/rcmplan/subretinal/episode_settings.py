"""Settings of one simulated subretinal-injection episode, checked before anything is built."""

from __future__ import annotations

from dataclasses import dataclass

from rcmplan._validate import scalar, vector
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.registry import check_robot
from rcmplan.subretinal.motion import BREATHING_BAND_HZ, CARDIAC_BAND_HZ
from rcmplan.subretinal.predictors import PREDICTORS

# The measured error of the ILM offset segmented from the synthetic B-scans with the needle held
# above the retina (docs/subretinal.md, 54200 B-scans): the `ioct_estimates="noise"` stand-in.
SEGMENTATION_BIAS_M = -1.26e-6
SEGMENTATION_STD_M = 0.23e-6
# Cardiac amplitude per unit of breathing amplitude: the MotionModel defaults (10 um / 50 um).
CARDIAC_PER_BREATHING = 0.2
PLANTS_SUPPORTED = ("kinematic", "mujoco")
# Where the controller's iOCT estimates come from (`episode_ioct`): each volume's B-scan rendered
# and segmented, or the measured-noise stand-in (the truth plus the measured bias and noise).
IOCT_ESTIMATES = ("image", "noise")
# Largest standard deviation per axis of the whole-eye translation [m] (a bound on absurd
# values: a quarter of the eye's 24 mm diameter).
EYE_DRIFT_MAX_M = 5e-3


@dataclass(frozen=True)
class EpisodeSettings:
    """One episode (SI units).

    Attributes:
        robot: A robot name or robot file (`rcmplan.robot.registry`).
        plant: The plant: "kinematic" or "mujoco" (the dynamic MuJoCo plant, whose servos
            follow the commands: the QP plans from its last command, `QpSolver`'s `servo`).
        compensation: Predictor of the ILM displacement: none, hold, fft or kalman.
        ioct_estimates: "image": each estimate segmented from the B-scan rendered from the
            true state at its acquisition; "noise": the measured-noise stand-in (the true
            displacement plus `SEGMENTATION_BIAS_M` and noise of `noise_std_m`, no image).
        ioct_rate_hz: iOCT volume rate [Hz].
        latency_s: iOCT latency, acquisition to delivery [s].
        breathing_m: Breathing amplitude along the normal [m].
        cardiac_amplitude_m: Cardiac amplitude along the normal [m]; None: `CARDIAC_PER_BREATHING`
            of the breathing amplitude.
        breathing_rate_hz: Nominal breathing rate [Hz], in the motion model's band (0.2-0.33).
        cardiac_rate_hz: Nominal heart rate [Hz], in the motion model's band (1-2).
        noise_std_m: Standard deviation of the stand-in's error [m] (its bias is the
            measured `SEGMENTATION_BIAS_M`); unused with "image" estimates.
        heart_rate_sd_hz: Error (1 sigma) [Hz] of the anaesthesia monitor's heart rate given
            to `kalman` (`monitor.py`); None: no heart rate given.
        seed: Seed of the motion and of the iOCT speckle (or the stand-in's noise).
        hold_s: Injection time at the target depth [s].
        standoff_m: Hover height above the ILM along the normal [m].
        target_fraction: Target depth between ILM (0) and RPE (1).
        band_fraction: Half-width of the target band as a fraction of the thickness.
        rpe_margin_m: The depth limit keeps the tip this far above the estimated RPE [m].
        depth_limit: Hold the depth limit in the QP (off only to show what it prevents).
        overshoot_m: Added to the commanded depth of the advance and the hold [m]: an operator
            pushing past the target (0 in a planned injection).
        puncture_depth_m: Least depth [m] below the predicted ILM the advance reaches: a
            shallower target is reached by advancing to this depth, where the ILM has given
            way, and withdrawing to the target (the withdraw phase). 120 um: the default
            tissue's 100 um tent at puncture and 20 % more (docs/subretinal.md).
        direction: Target location: a direction from the eye centre in the eye frame.
        start_height_m: Start height of the tip above the undisplaced ILM [m].
        warmup_s: iOCT observation before the approach (the needle still) [s].
        hover_s: Hover above the target before the advance [s].
        approach_speed_m_s: Tip speed of the approach to the stand-off [m/s].
        advance_speed_m_s: Tip speed of the advance and the retraction [m/s].
        settle_s: Time at the stand-off after the retraction [s].
        dt: Control period [s].
        rcm_bound_m: RCM deviation [m] that stops the episode.
        eye_drift_m: Standard deviation per axis [m] of the whole-eye translation T(t) (the
            motion model's OU process), which carries the retina, the target and the trocar;
            0: the eye stays put. At most `EYE_DRIFT_MAX_M`; kinematic plant only.
        eye_drift_time_s: Correlation time of the whole-eye translation [s].
    """

    robot: str = "iramis"
    plant: str = "kinematic"
    compensation: str = "kalman"
    ioct_estimates: str = "image"
    ioct_rate_hz: float = 9.0
    latency_s: float = 0.15
    breathing_m: float = 50e-6
    cardiac_amplitude_m: float | None = None
    breathing_rate_hz: float = 0.25
    cardiac_rate_hz: float = 1.5
    noise_std_m: float = SEGMENTATION_STD_M
    heart_rate_sd_hz: float | None = None
    seed: int = 0
    hold_s: float = 5.0
    standoff_m: float = 100e-6
    target_fraction: float = 0.5
    band_fraction: float = 0.1
    rpe_margin_m: float = 25e-6
    depth_limit: bool = True
    overshoot_m: float = 0.0
    puncture_depth_m: float = 120e-6
    direction: tuple[float, float, float] = (0.1, 0.0, 1.0)
    start_height_m: float = 500e-6
    warmup_s: float = 10.0
    hover_s: float = 1.0
    approach_speed_m_s: float = 0.5e-3
    advance_speed_m_s: float = 0.2e-3
    settle_s: float = 0.3
    dt: float = 1e-3
    rcm_bound_m: float = 45e-6
    eye_drift_m: float = 0.0
    eye_drift_time_s: float = 30.0

    def __post_init__(self) -> None:
        check_robot(self.robot)
        if self.plant not in PLANTS_SUPPORTED:
            raise InvalidInputError("plant", self.plant, f"one of {list(PLANTS_SUPPORTED)}")
        if self.compensation not in PREDICTORS:
            valid = "one of " + ", ".join(PREDICTORS)
            raise InvalidInputError("compensation", self.compensation, valid)
        if self.ioct_estimates not in IOCT_ESTIMATES:
            valid = "one of " + ", ".join(IOCT_ESTIMATES)
            raise InvalidInputError("ioct_estimates", self.ioct_estimates, valid)
        scalar("ioct_rate_hz", self.ioct_rate_hz, 0.5, 200.0)
        scalar("latency_s", self.latency_s, 0.0, 1.0)
        scalar("breathing_m", self.breathing_m, 0.0, 200e-6)
        if self.cardiac_amplitude_m is not None:
            scalar("cardiac_amplitude_m", self.cardiac_amplitude_m, 0.0, 200e-6)
        scalar("breathing_rate_hz", self.breathing_rate_hz, *BREATHING_BAND_HZ)
        scalar("cardiac_rate_hz", self.cardiac_rate_hz, *CARDIAC_BAND_HZ)
        scalar("noise_std_m", self.noise_std_m, 0.0, 50e-6)
        if self.heart_rate_sd_hz is not None:
            scalar("heart_rate_sd_hz", self.heart_rate_sd_hz, 0.0, 1.0)
        if not isinstance(self.seed, int) or not 0 <= self.seed < 2**32:
            raise InvalidInputError("seed", self.seed, "an integer in [0, 2**32)")
        scalar("hold_s", self.hold_s, 0.0, 60.0, low_open=True)
        scalar("standoff_m", self.standoff_m, 20e-6, 1e-3)
        scalar("rpe_margin_m", self.rpe_margin_m, 0.0, 200e-6)
        scalar("overshoot_m", self.overshoot_m, 0.0, 500e-6)
        scalar("puncture_depth_m", self.puncture_depth_m, 0.0, 600e-6)
        object.__setattr__(self, "direction", tuple(vector("direction", self.direction, 3)))
        scalar("start_height_m", self.start_height_m, self.standoff_m, 3e-3)
        scalar("warmup_s", self.warmup_s, 0.0, 60.0)
        scalar("hover_s", self.hover_s, 0.0, 60.0)
        scalar("approach_speed_m_s", self.approach_speed_m_s, 1e-5, 5e-3)
        scalar("advance_speed_m_s", self.advance_speed_m_s, 1e-5, 5e-3)
        scalar("settle_s", self.settle_s, 0.0, 10.0)
        scalar("dt", self.dt, 1e-4, 1e-2)
        scalar("rcm_bound_m", self.rcm_bound_m, 0.0, 1e-3, low_open=True)
        scalar("eye_drift_m", self.eye_drift_m, 0.0, EYE_DRIFT_MAX_M)
        scalar("eye_drift_time_s", self.eye_drift_time_s, 0.1, 1e4)

    @property
    def cardiac_m(self) -> float:
        """Cardiac amplitude along the normal [m]."""
        if self.cardiac_amplitude_m is not None:
            return self.cardiac_amplitude_m
        return CARDIAC_PER_BREATHING * self.breathing_m
