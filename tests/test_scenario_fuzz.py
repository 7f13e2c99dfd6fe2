"""Generated scenario files (600 per run, seeded; 1,600 with RCMPLAN_HEAVY_TESTS=1): each
loads as a valid Scenario or raises a typed rcmplan error with a one-line message, never a
generic Python error, nor a RuntimeWarning on the way (raised as an error here)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from heavy import cases
from rcmplan.exceptions import InvalidInputError, PlanTooLargeError, RcmplanError, ScenarioError
from rcmplan.robot.iramis import Iramis
from rcmplan.scene.scenario import Scenario, load_scenario
from rcmplan.scene.schema import SCHEMA

pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")
SETTINGS = settings(
    max_examples=cases(300, 800), derandomize=True, database=None, deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)  # fmt: skip
KEYS = [(sec, key) for sec, keys in SCHEMA.items() for key in keys] + [
    ("qp", k) for k in ("contacts_mm", "eye_gain", "rcm_tolerance_um", "solver", "zzz")
]

scalars = st.one_of(
    st.booleans(),
    st.integers(min_value=-(10**30), max_value=10**30),
    st.integers(min_value=-3, max_value=300),
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(min_value=-50, max_value=50),
    st.sampled_from(["nan", "inf", "-inf", "pinv", "qp", "kinematic", "p4", ""]),
    st.text(max_size=8),
)
keys = st.text(max_size=4)
values = st.recursive(
    scalars,
    lambda inner: st.lists(inner, max_size=7) | st.dictionaries(keys, inner, max_size=3),
    max_leaves=12,
)
entries = st.lists(st.tuples(st.sampled_from(KEYS), values), max_size=6)


def toml_value(v: Any) -> str:
    """v as a TOML value (floats' nan and inf as TOML spells them)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, int | float):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return "{" + ", ".join(f"{json.dumps(k)} = {toml_value(x)}" for k, x in v.items()) + "}"


def toml_text(pairs: list[tuple[tuple[str, str], Any]]) -> str:
    """A scenario file from (section, key) -> value pairs (repeated keys are TOML errors)."""
    top = [f"{key} = {toml_value(v)}" for (sec, key), v in pairs if not sec]
    lines = [*top]
    for (sec, key), v in pairs:
        if sec:
            lines += [f"[{sec}]", f"{key} = {toml_value(v)}"]
    return "\n".join(lines) + "\n"


def load(path: Path, data: bytes) -> Scenario | RcmplanError:
    """Load data as a scenario file: the Scenario or the typed error (anything else fails)."""
    path.write_bytes(data)
    try:
        return load_scenario(path)
    except InvalidInputError as exc:
        assert "\n" not in str(exc) and exc.name
        return exc


@SETTINGS
@given(pairs=entries)
def test_generated_scenario_files_load_or_raise_a_typed_one_line_error(
    tmp_path: Path, pairs: list[tuple[tuple[str, str], Any]]
) -> None:
    result = load(tmp_path / "s.toml", toml_text(pairs).encode("utf-8", "surrogatepass"))
    assert isinstance(result, Scenario | RcmplanError)


BASE = (Path(__file__).parents[1] / "src/rcmplan/scenarios/default.toml").read_bytes()


@SETTINGS
@given(
    cut=st.integers(0, len(BASE)),
    junk=st.binary(max_size=12),
    where=st.integers(0, len(BASE)),
    drop=st.booleans(),
)
def test_truncated_and_corrupted_files_load_or_raise_a_typed_error(
    tmp_path: Path, cut: int, junk: bytes, where: int, drop: bool
) -> None:
    data = BASE[:cut] if drop else BASE[:where] + junk + BASE[where:]
    assert isinstance(load(tmp_path / "s.toml", data), Scenario | RcmplanError)


@settings(max_examples=60, derandomize=True, database=None, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])  # fmt: skip
@given(
    position_mm=st.floats(*SCHEMA["steps"]["position_mm"][1:]),
    angle_mrad=st.floats(*SCHEMA["steps"]["angle_mrad"][1:]),
)
def test_schema_valid_step_sizes_plan_within_the_cap_or_are_refused(
    tmp_path: Path, position_mm: float, angle_mrad: float
) -> None:
    text = f"[steps]\nposition_mm = {position_mm!r}\nangle_mrad = {angle_mrad!r}\n"
    scenario = load(tmp_path / "s.toml", text.encode())
    if isinstance(scenario, ScenarioError):  # within the range, beyond the tolerance's margin
        assert position_mm > 0.9999 and "at most 0.99998" in str(scenario)
        return
    assert isinstance(scenario, Scenario)
    try:
        phases = scenario.phases(Iramis())
    except PlanTooLargeError as exc:
        assert "200,000" in str(exc)
        return
    assert sum(len(p.targets) for p in phases if not callable(p.targets)) > 0


@pytest.mark.parametrize(
    ("data", "named"),
    [
        (bytes(range(256)), "byte 0x80 at offset 128"),
        ('name = "caf\xe9"\n'.encode("latin-1"), "byte 0xe9"),
        (b"a = " + b"[" * 5000 + b"]" * 5000, "nested"),
        (b"[eye]\nradius_mm = 1" + b"0" * 400, "[eye] radius_mm"),
        (b'[qp]\ncontacts_mm = "abc"\n', "[qp] contacts_mm"),
        (b"[eye]\nradius_mm = nan\n", "[eye] radius_mm"),
        (b"[eye]\nfoo = 1\n", "foo"),
    ],
)
def test_malformed_files_name_the_key_or_the_byte(tmp_path: Path, data: bytes, named: str) -> None:
    result = load(tmp_path / "s.toml", data)
    assert isinstance(result, RcmplanError) and named in str(result)
