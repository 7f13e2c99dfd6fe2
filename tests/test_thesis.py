"""The thesis experiments as interpreted, and the reproduce command."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from rcmplan.analysis import thesis
from rcmplan.cli import main


def test_pivot_alignment_runs_500_steps_with_both_settings() -> None:
    for setting in ("thesis", "rcmplan"):
        o = thesis.pivot_alignment(setting)
        assert o.status == "ok"
        assert o.steps == 500
        assert o.max_rcm_deviation_m is not None and o.max_rcm_deviation_m <= 30e-6


def test_thesis_gain_keeps_the_printed_ratios_inside_the_newton_range() -> None:
    ratios = [k / thesis.THESIS_K[0] for k in thesis.THESIS_K]
    assert ratios == pytest.approx([1, 10, 12, 1, 2, 2], rel=1e-12)
    assert all(0 < k < 2 for k in thesis.THESIS_K)


def test_reproduce_writes_a_row_per_experiment(tmp_path: Path, capsys) -> None:
    assert main(["reproduce", "--out", str(tmp_path), "--json", "--no-plots"]) == 0
    doc = json.loads(capsys.readouterr().out)
    rows = doc["experiments"]
    assert [r["experiment"] for r in rows] == list(thesis.EXPERIMENTS)
    for r in rows:
        assert r["rcmplan"]["status"] == "ok"
        assert r["rcmplan"]["max_rcm_deviation_m"] <= 1e-6
    assert json.loads((tmp_path / "summary.json").read_text()) == doc


def test_a_setting_that_skips_steps_is_drawn_at_its_own_control_steps() -> None:
    """The hypothesised V-REP spiral iterates only on steps whose error exceeds its 0.1 mm
    precision: its points sit at their control steps (increasing, up to the spiral's end),
    not packed at the start of the axis."""
    import numpy as np

    from rcmplan.cli import thesis_hypothesis
    from rcmplan.cli.thesis_figures import step_numbers

    o = thesis_hypothesis.EXPERIMENTS["spiral"]()
    sub = o.log.select(np.all(np.isfinite(o.log.trocar), axis=1))
    x = step_numbers(sub)
    assert len(x) < o.steps  # some steps took no iteration
    assert np.all(np.diff(x) > 0) and x[0] >= 1
    assert x[-1] > 0.9 * o.steps  # the last points lie near the spiral's end
