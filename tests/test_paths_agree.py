"""The reference and compiled paths give the same status on the same input: generated scenario
settings (method, gains, damping, tolerances, steps, iteration cap, RCM bound; seeded) run on
both, and each run's status, message and record count agree."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from heavy import cases
from rcmplan.job import run_scenario
from rcmplan.scene.scenario import scenario_from_dict

from paths import use_path

controllers = st.fixed_dictionaries(
    {"method": st.sampled_from(["pinv", "pinv-thesis", "dls"])},
    optional={
        "K": st.lists(st.floats(0.05, 1.99), min_size=6, max_size=6),
        "damping": st.floats(1e-6, 1e-2),
        "tolerance_position_m": st.floats(1e-10, 1e-5),
        "tolerance_angle_rad": st.floats(1e-9, 1e-4),
        "max_iterations": st.integers(1, 100),
        "rcm_bound_um": st.floats(0.05, 100.0),
    },
)
steps = st.fixed_dictionaries(
    {}, optional={"position_mm": st.floats(0.2, 0.99), "angle_mrad": st.floats(2.0, 100.0)}
)


@pytest.fixture(autouse=True)
def _mode_restored() -> Iterator[None]:
    yield
    use_path(None)


def outcome(data: dict[str, Any], mode: str) -> tuple[str, str, int]:
    """(status, message, records) of the scenario on one path."""
    use_path(mode)
    result = run_scenario(scenario_from_dict(data))
    return result.status, result.message, len(result.log)


@settings(max_examples=cases(15, 60), derandomize=True, database=None, deadline=None)
@given(controller=controllers, step_sizes=steps)
def test_reference_and_compiled_paths_give_the_same_status(
    controller: dict[str, Any], step_sizes: dict[str, Any]
) -> None:
    data = {"controller": controller, "steps": step_sizes}
    ref, fast = outcome(data, "off"), outcome(data, "on")
    assert fast[0] == ref[0], (ref, fast)
    if ref[0] == "ok":
        assert fast[2] == ref[2]
