"""Run figures: per-step envelopes, phase bands, trocar frame, named targets, failed methods, and
every figure readable as drawn (no legend over an axes, bounds beneath the data, the tip panel
drawing the figures the summary names, phase labels apart)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from figcheck import legend_clashes
from rcmplan.analysis import plots, style
from rcmplan.analysis.plots_compare import comparison_title, failure_kind, method_comparison
from rcmplan.analysis.report import rcm_bounds, tip_bounds, visited_points
from rcmplan.analysis.result import RunResult
from rcmplan.control.log import LogBuilder, RunLog
from rcmplan.job import run_scenario
from rcmplan.scene.eye import default_eye
from rcmplan.scene.scenario import load_scenario


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


# --- figures readable as drawn -----------------------------------------------------------------
@pytest.fixture
def drawn(monkeypatch) -> Iterator[list[Any]]:
    """The figures the plot functions make, kept open instead of saved."""
    figs: list[Any] = []
    monkeypatch.setattr(style, "save", lambda fig, path: figs.append(fig) or Path(path))
    yield figs
    for fig in figs:
        style.plt().close(fig)


def test_a_method_beyond_its_bounds_keeps_its_bars_and_is_named_in_the_title(drawn) -> None:
    """limit_violated: every phase ran, so its figures are drawn; the title names it."""
    ok = {"max_rcm_deviation_m": 4e-7, "iterations": 10, "wall_time_s": 0.01,
          "wall_time_per_iteration_s": 1e-3}  # fmt: skip
    rows = [{"method": "pinv", "status": "ok", **ok},
            {"method": "qp", "status": "limit_violated", **ok, "max_rcm_deviation_m": 1.77e-6},
            {"method": "dls", "status": "no_convergence", **ok}]  # fmt: skip
    method_comparison(rows, Path("unused.png"))
    rcm_panel = drawn[0].axes[0]
    heights = [bar.get_height() for bar in rcm_panel.patches]
    assert heights[:2] == pytest.approx([0.4, 1.77]) and np.isnan(heights[2])
    title = drawn[0]._suptitle.get_text()
    assert title.endswith("did not finish: dls (no_convergence); beyond their bounds: qp")
    # every finished bar carries its value, inside the panel
    assert [t.get_text() for t in rcm_panel.texts][:2] == ["0.400", "1.77"]
    assert labels_outside(drawn[0]) == []


def labels_outside(fig: Any) -> list[tuple[str, str]]:
    """(panel title, text) of each text of the figure's panels that reaches above the frame."""
    renderer = fig.canvas.get_renderer()
    out = []
    for ax in fig.axes:
        frame = ax.get_window_extent(renderer)
        for t in ax.texts:
            if t.get_text() and t.get_window_extent(renderer).y1 > frame.y1 + 0.5:
                out.append((ax.get_title(), t.get_text()))
    return out


def test_a_panel_whose_values_are_all_zero_keeps_its_labels_inside(drawn) -> None:
    zero = {"max_rcm_deviation_m": 0.0, "iterations": 0, "wall_time_s": 0.01,
            "wall_time_per_iteration_s": 1e-3}  # fmt: skip
    method_comparison([{"method": "pinv", "status": "ok", **zero}], Path("unused.png"))
    assert labels_outside(drawn[0]) == []


def run_figures(result: RunResult, figs: list[Any], tmp: Path) -> dict[str, Any]:
    """The three run figures of `write_figures`, drawn, by name."""
    eye, log = result.scenario.eye(result.robot), result.log
    plots.rcm_deviation_envelope(log, eye, tmp / "a.png", rcm_bounds(result))
    plots.rcm_trace(log, eye, tmp / "b.png")
    plots.tip_path(log, eye, {}, tmp / "c.png", tip_bounds(result))
    for fig in figs:
        fig.canvas.draw()
    return dict(zip(("rcm_deviation", "rcm_trace", "tip_path"), figs, strict=True))


@pytest.fixture(scope="module", params=["pinv", "qp"])
def result(request) -> RunResult:
    return run_scenario(load_scenario("default").with_method(request.param))


def test_no_legend_lies_over_an_axes_of_its_figure(result, drawn, tmp_path) -> None:
    for name, fig in run_figures(result, drawn, tmp_path).items():
        assert [*fig.legends, *(a.get_legend() for a in fig.axes if a.get_legend())], name
        assert legend_clashes(fig) == [], name


def test_bounds_lie_beneath_every_data_line(result, drawn, tmp_path) -> None:
    bound_names = [label for label, _ in (*rcm_bounds(result), *tip_bounds(result))]
    figs = run_figures(result, drawn, tmp_path)
    for name in ("rcm_deviation", "tip_path"):
        for ax in figs[name].axes:
            lines = [ln for ln in ax.get_lines() if not ln.get_label().startswith("_")]
            bounds = [ln for ln in lines if ln.get_label().startswith(tuple(bound_names))]
            data = [ln for ln in lines if ln not in bounds]
            if bounds:
                assert max(b.get_zorder() for b in bounds) < min(d.get_zorder() for d in data)


def test_the_tip_panel_draws_the_tracking_and_waypoint_errors_the_summary_reports(
    result, drawn, tmp_path
) -> None:
    s = result.summary()
    ax = [a for a in run_figures(result, drawn, tmp_path)["tip_path"].axes if a.get_lines()][-1]
    lines = {ln.get_label(): ln.get_ydata() for ln in ax.get_lines()}
    tracking = lines["tracking error, largest in the step"]
    waypoint = lines["waypoint tip error, at the step's end"]
    worst = max(p["max_tracking_error_m"] for p in s["phases"])
    assert np.max(tracking) == pytest.approx(worst * 1e6, rel=1e-12)
    assert np.max(waypoint) == pytest.approx(s["max_waypoint_tip_error_m"] * 1e6, rel=1e-12)
    floor = ax.get_ylim()[0]
    assert np.mean(tracking > floor) > 0.5  # the panel shows its data, not its axis floor


def test_crowded_phase_labels_move_apart_and_keep_their_order() -> None:
    x = style.spread([0.0, 0.1, 0.2, 5.0], [0.5, 0.5, 0.5, 1.0])
    assert np.all(np.diff(x[:3]) >= 0.5 - 1e-12)
    assert np.mean(x[:3]) == pytest.approx(0.1) and x[3] == 5.0  # a free label stays put
    assert style.spread([], []) == []


def test_phase_strip_labels_do_not_overlap_on_a_run_with_short_phases() -> None:
    plt = style.plt()
    names = ["approach", "align", "insert", "to-spiral", "spiral", "from-spiral", "retract",
             "withdraw"]  # fmt: skip
    counts = [40, 120, 40, 140, 2960, 358, 40, 25]  # the spiral's records per phase
    edges = np.concatenate([[0.0], np.cumsum(counts) * 1e-3])
    spans = [(n, float(a), float(b)) for n, a, b in zip(names, edges, edges[1:], strict=False)]
    fig, (strip, ax) = style.time_axes(plt)
    style.phase_strip(strip, spans)
    ax.plot(edges, edges)
    fig.canvas.draw()
    boxes = [t.get_window_extent() for t in strip.texts]
    plt.close(fig)
    assert [t.get_text() for t in strip.texts] == names
    for i, a in enumerate(boxes):
        for b in boxes[i + 1 :]:
            assert not a.overlaps(b)


def test_comparison_log_panels_start_at_a_whole_decade_below_the_smallest_bar(drawn) -> None:
    rows = [{"method": m, "status": "ok", "max_rcm_deviation_m": 4e-7, "iterations": n,
             "wall_time_s": w, "wall_time_per_iteration_s": w / n}
            for m, n, w in (("pinv", 1465, 0.065), ("qp", 27664, 1.9))]  # fmt: skip
    method_comparison(rows, Path("unused.png"))
    logs = [ax for ax in drawn[0].axes if ax.get_yscale() == "log"]
    assert len(logs) == 2
    for ax, smallest in zip(logs, (65.0, 0.065 / 1465 * 1e6), strict=True):
        bottom = ax.get_ylim()[0]
        assert bottom == 10.0 ** np.floor(np.log10(smallest)) and bottom < smallest
