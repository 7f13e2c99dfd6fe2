"""Run figures: per-step envelopes, phase bands, trocar frame, named targets, failed methods."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rcmplan.analysis import plots, style
from rcmplan.analysis.plots_compare import comparison_title, failure_kind, method_comparison
from rcmplan.analysis.report import visited_points
from rcmplan.control.log import LogBuilder, RunLog
from rcmplan.scene.eye import default_eye


def synthetic_log(steps: list[tuple[int, int, float]], dt: float = 1e-3) -> RunLog:
    """Records (phase id, step index, RCM offset along x in m), one per control iteration."""
    b = LogBuilder()
    for name in ("first", "second"):
        b.phase_id(name)
    b.solver_id("pinv")
    for i, (phase, step, dx) in enumerate(steps):
        p = np.array([0.1, 0.0, 0.0])
        b.append(time=(i + 1) * dt, sliders=np.zeros(6), joints=np.zeros(6), lam=0.5,
                 tip=p, rcm=p + [dx, 0.0, 0.0], trocar=p, base=p, target_tip=p,
                 error=np.zeros(6), step=step, iteration=1, solver=0, phase=phase)  # fmt: skip
    return b.finish()


def test_step_envelope_keeps_the_largest_value_of_each_control_step() -> None:
    log = synthetic_log([(0, 0, 3.0), (0, 0, 1.0), (0, 1, 2.0), (1, 0, 5.0), (1, 0, 4.0)])
    t, env = plots.step_envelope(log, np.abs(log.rcm_deviation()[:, 0]))
    assert env.tolist() == [3.0, 2.0, 5.0]
    assert np.allclose(t, [0.002, 0.003, 0.005])


def test_a_new_phase_starts_a_new_step_even_with_the_same_step_index() -> None:
    log = synthetic_log([(0, 0, 1.0), (1, 0, 2.0)])
    starts, ends = plots.step_starts(log)
    assert starts.tolist() == [0, 1] and ends.tolist() == [0, 1]


def test_phase_spans_are_named_in_order_and_adjacent_spans_meet() -> None:
    log = synthetic_log([(0, 0, 0.0), (0, 1, 0.0), (1, 0, 0.0), (1, 1, 0.0)])
    spans = style.phase_spans(log)
    assert [s[0] for s in spans] == ["first", "second"]
    assert spans[0][2] == pytest.approx(spans[1][1])
    assert spans[0][1] == pytest.approx(0.0) and spans[1][2] == pytest.approx(0.004)


def test_trocar_frame_is_orthonormal_with_n_the_insertion_axis(robot) -> None:
    eye = default_eye(robot)
    e1, e2, n = plots.trocar_frame(eye)
    frame = np.array([e1, e2, n])
    assert np.allclose(frame @ frame.T, np.eye(3))
    assert np.allclose(n, eye.axis)
    assert abs(e1[2]) < 1e-12  # e1 is horizontal in the base frame


def test_only_points_the_commanded_path_reaches_are_labelled() -> None:
    log = synthetic_log([(0, 0, 0.0)])
    points = {"p1": np.array([0.1, 0.0, 0.0]), "p7": np.array([0.1, 0.01, 0.0])}
    assert list(visited_points(log, points)) == ["p1"]


def test_failed_methods_are_named_with_their_error_in_the_title() -> None:
    rows = [
        {"method": "pinv", "status": "ok"},
        {"method": "qp", "status": "ConvergenceError: no step after 100 iterations"},
    ]
    assert failure_kind(rows[1]["status"]) == "ConvergenceError"
    assert comparison_title(rows).endswith("did not finish: qp (ConvergenceError)")
    assert "did not finish" not in comparison_title(rows[:1])


def test_comparison_chart_is_written_with_a_failed_method(tmp_path: Path) -> None:
    ok = {"max_rcm_deviation_m": 4e-7, "iterations": 10, "wall_time_s": 0.01,
          "wall_time_per_iteration_s": 1e-3}  # fmt: skip
    rows = [{"method": "pinv", "status": "ok", **ok},
            {"method": "dls", "status": "SliderLimitError: L1", **ok}]  # fmt: skip
    path = method_comparison(rows, tmp_path / "c.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
