"""Reach maps of a curved needle beside its straight shaft (poses only)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rcmplan.robot.curved import curved_robot
from rcmplan.robot.curved_needle import CurvedNeedle
from rcmplan.robot.registry import make_robot
from rcmplan.scene.eye import default_eye
from rcmplan.scene.reach import reach_map, retina_lattice


def test_the_lattice_covers_the_retina_in_front_of_the_trocar_with_equal_cells() -> None:
    eye = default_eye(make_robot("iramis"))
    pts, cell = retina_lattice(eye, 500)
    assert np.allclose(np.linalg.norm(pts - eye.center, axis=1), eye.retina_radius)
    assert np.all((pts - eye.port) @ eye.axis > 0.0)
    assert cell == pytest.approx(4 * math.pi * eye.retina_radius**2 / 500)


def test_a_curved_needle_reaches_the_retina_at_a_wider_range_of_angles() -> None:
    base = make_robot("iramis")
    robot = curved_robot(base, CurvedNeedle(base.needle_length))
    m = reach_map(robot, default_eye(robot), n=60, rolls=4)
    s = m.summary()
    assert s["straight_area_mm2"] > 0.0 and s["curved_area_mm2"] > 0.0
    assert s["curved_min_angle_median_rad"] < s["straight_angle_median_rad"]
    assert s["curved_angle_span_median_rad"] > 0.1


def test_the_sweep_of_the_curved_scenario_writes_the_reach_summary(tmp_path, capsys) -> None:
    from rcmplan.cli import main

    assert main(["sweep", "--scenario", "curved", "--targets", "40", "--json",
                 "--out", str(tmp_path)]) == 0  # fmt: skip
    text = (tmp_path / "summary.json").read_text()
    assert '"needle": "curved"' in text and "area_ratio" in text
