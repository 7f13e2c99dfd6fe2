"""A subretinal episode on the dynamic MuJoCo plant: the QP step planned from the plant's last
command (its servos lag), compiled, the RCM held, and a run that is the plant's, not the
kinematic plant's; and a batch of episodes on it."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from rcmplan.cli import main
from rcmplan.sim.mujoco.plant import MujocoPlant
from rcmplan.subretinal.episode import Episode, EpisodeResult
from rcmplan.subretinal.episode_metrics import summarise
from rcmplan.subretinal.episode_settings import EpisodeSettings

# Short episodes: 0.2 mm approach, 0.5 s hover, 1 s hold, a faster advance (3.125 s in all).
SHORT = EpisodeSettings(hold_s=1.0, start_height_m=200e-6, hover_s=0.5, advance_speed_m_s=0.4e-3,
                        seed=3)  # fmt: skip


@pytest.fixture(scope="module")
def runs() -> dict[str, tuple[Episode, EpisodeResult]]:
    """The same short kalman episode on both plants, on the iOCT stand-in: the same estimates
    on both (images of the two plants' tips would differ), so that the runs differ by the
    plant alone. The batch below runs MuJoCo on segmented images."""
    out = {}
    for plant in ("mujoco", "kinematic"):
        ep = Episode(replace(SHORT, plant=plant, ioct_estimates="noise"))
        out[plant] = (ep, ep.run())
    return out


def test_the_episode_runs_on_mujoco_with_the_servo_plan_compiled(
    runs: dict[str, tuple[Episode, EpisodeResult]],
) -> None:
    ep, _ = runs["mujoco"]
    assert isinstance(ep.plant, MujocoPlant) and ep.plant.mode == "dynamic"
    assert ep.solver.servo is ep.plant  # steps planned from the plant's last command
    assert ep.fast_step is not None and ep.blocks is None  # per period, the step compiled
    kin, _ = runs["kinematic"]
    assert kin.solver.servo is None and kin.blocks is not None


def test_mujoco_holds_the_rcm_and_the_target_band(
    runs: dict[str, tuple[Episode, EpisodeResult]],
) -> None:
    ep, result = runs["mujoco"]
    doc = summarise(result)
    assert doc["status"] == "ok" and doc["plant"] == "mujoco" and doc["punctured"]
    assert len(result.log) == result.series["t_s"].size == ep.n_periods > 3000
    assert doc["max_rcm_deviation_m"] <= 2e-6
    assert result.log.max_rcm_deviation() <= 2e-6
    assert doc["in_band_fraction"] == 1.0 and not doc["rpe_breach"]
    assert doc["tracking_rms_m"] < 10e-6


def test_the_mujoco_run_is_the_plants_own(runs: dict[str, tuple[Episode, EpisodeResult]]) -> None:
    """The dynamic plant lags and rounds its commands: the needle leaves the trocar by a
    fraction of a micrometre where the kinematic plant keeps it to rounding, and the sliders
    differ, while both follow the same plan."""
    (mj_ep, mj), (_, kin) = runs["mujoco"], runs["kinematic"]
    assert kin.log.max_rcm_deviation() < 1e-11 < 1e-8 < mj.log.max_rcm_deviation()
    gap = np.abs(mj.log.sliders - kin.log.sliders)[:, :5].max()
    assert 1e-9 <= gap < 5e-6
    np.testing.assert_array_equal(mj.series["command_depth_m"], kin.series["command_depth_m"])
    lag = mj_ep.plant.command - mj_ep.plant.read_actuators()
    assert np.abs(lag[:5]).max() > 0.0  # the servo has not reached its last command exactly


def test_episodes_run_on_mujoco(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["subretinal", "--plant", "mujoco", "--episodes", "1", "--compensation", "kalman",
            "--hold-s", "0.2", "--hover-s", "0.1", "--workers", "1", "--json", "--no-plots",
            "--out", str(tmp_path)]  # fmt: skip
    assert main(argv) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["settings"]["base"]["plant"] == "mujoco"
    kalman = doc["methods"]["kalman"]
    assert kalman["episodes"] == 1 and kalman["statuses"] == {"ok": 1}
    assert 0.0 < kalman["max_rcm_deviation_m"] <= 2e-6
