"""A subretinal episode's planned periods as one compiled call (`episode_blocks`) against the
same episode one period at a time (`Episode.period`): the same records, the same stops."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from rcmplan.compiled.qp_periods import RCM_BOUND
from rcmplan.compiled.records import QP_FAILED
from rcmplan.exceptions import QPError
from rcmplan.subretinal.episode import Episode, EpisodeResult
from rcmplan.subretinal.episode_settings import EpisodeSettings

from logcheck import assert_same_log

# Short episodes: 0.2 mm approach, 0.5 s hover, 1 s hold, a faster advance.
SHORT = EpisodeSettings(hold_s=1.0, start_height_m=200e-6, hover_s=0.5, advance_speed_m_s=0.4e-3,
                        seed=3)  # fmt: skip
# Target 225 um deep and an operator pushing 50 um further: the depth limit holds the tip.
DEEP = replace(SHORT, compensation="hold", target_fraction=0.9, band_fraction=0.05,
               overshoot_m=50e-6)  # fmt: skip


def episode(cfg: EpisodeSettings, blocks: bool) -> Episode:
    """An episode on the compiled block loop (which must apply) or one period at a time."""
    ep = Episode(cfg)
    if ep.blocks is None:
        pytest.skip("the compiled block loop does not apply here (no callable DAQP C solver)")
    if not blocks:
        ep.blocks = None
    return ep


def assert_same_result(a: EpisodeResult, b: EpisodeResult) -> None:
    """Same status and message, series within 1e-12 (m, s; ids exact), logs within 1e-12."""
    assert (a.status, a.message) == (b.status, b.message)
    assert a.series.keys() == b.series.keys()
    for key in a.series:
        np.testing.assert_allclose(a.series[key], b.series[key], rtol=0, atol=1e-12, err_msg=key)
    assert_same_log(a.log, b.log, 1e-12, nonempty=True)


# The same with the eye moving (500 um per axis): the trocar and the depth limit's centre move.
MOVING, DEEP_MOVING = (replace(c, eye_drift_m=500e-6) for c in (SHORT, DEEP))


@pytest.mark.parametrize("cfg", [SHORT, DEEP, MOVING, DEEP_MOVING],
                         ids=["kalman", "deep-hold", "kalman-eye-drift", "deep-hold-eye-drift"])  # fmt: skip
def test_blocks_give_the_per_period_records(cfg: EpisodeSettings) -> None:
    blocked = episode(cfg, blocks=True).run()
    single = episode(cfg, blocks=False).run()
    assert blocked.status == "ok" and len(blocked.log) == blocked.series["t_s"].size > 3000
    assert_same_result(blocked, single)
    if cfg.overshoot_m > 0:  # the moving floor was active: the tip went as deep as the limit let it
        s = blocked.series
        floor_depth = s["limit_m"] + blocked.layers.thickness_m - cfg.rpe_margin_m
        tip = s["depth_vs_undeformed_m"] + s["wall_m"]
        assert np.min(floor_depth - tip) < 1e-6


def test_an_rcm_bound_stops_both_paths_at_the_same_period() -> None:
    free = episode(SHORT, blocks=True).run()
    bound = 0.5 * float(free.series["rcm_deviation_m"].max())
    cfg = replace(SHORT, rcm_bound_m=bound)
    blocked = episode(cfg, blocks=True).run()
    single = episode(cfg, blocks=False).run()
    assert blocked.status == "rcm_bound_exceeded"
    n = blocked.series["t_s"].size
    assert 0 < n < free.series["t_s"].size and blocked.series["rcm_deviation_m"][-1] > bound
    assert np.all(blocked.series["rcm_deviation_m"][:-1] <= bound)
    assert_same_result(blocked, single)


class StopAt:
    """The block kernel with a solve failing (compiled only) at period `at` of the episode."""

    def __init__(self, kernels: Any, ep: Episode, at: int) -> None:
        self.kernels, self.ep, self.at = kernels, ep, at
        self.RCM_BOUND = RCM_BOUND

    def run_periods(self, *args: Any) -> int:
        k = self.ep.done
        n = args[7].shape[0]  # the block's times
        if not k <= self.at < k + n:
            return int(self.kernels.run_periods(*args))
        cut = self.at - k
        per_period = (6, 7, 8, 9, 10, 11, 13, 14)  # trocars .. centers, rec, deviation
        head = [a[:cut] if i in per_period else a for i, a in enumerate(args)]
        self.kernels.run_periods(*head)
        args[15][1] = -1  # the exit flag
        return QP_FAILED


def test_a_failed_solve_goes_to_the_per_period_step() -> None:
    """A solve failing in compiled code only: the period's reference step, then on."""
    ep = episode(SHORT, blocks=True)
    assert ep.blocks is not None
    at = 1234
    ep.blocks.kernels = StopAt(ep.blocks.kernels, ep, at)  # type: ignore[assignment]
    replayed = []
    fast = ep.fast_step
    assert fast is not None

    def step(*args: Any) -> Any:
        replayed.append(ep.done)
        return fast(*args)

    ep.fast_step = step
    result = ep.run()
    assert replayed == [at]
    assert_same_result(result, episode(SHORT, blocks=False).run())


def test_a_failed_solve_ends_the_episode_with_its_records() -> None:
    """A solve the reference step fails too: its QPError, the periods before it logged."""
    ep = episode(SHORT, blocks=True)
    assert ep.blocks is not None
    at = 777
    ep.blocks.kernels = StopAt(ep.blocks.kernels, ep, at)  # type: ignore[assignment]

    def step(*args: Any) -> Any:
        raise QPError("QP solve failed: infeasible")

    ep.fast_step = step
    with pytest.raises(QPError):
        ep.run()
    assert ep.done == len(ep.log) == at
    np.testing.assert_array_equal(ep.log.finish().step, np.arange(at))
