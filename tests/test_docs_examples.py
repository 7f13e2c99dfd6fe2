"""The Python examples of docs/ that run without a user's own files run as written (those of
docs/robots.md load the user's URDF, `my_arm.urdf`; the README's are in test_readme.py)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"


def block(name: str, index: int = 0) -> str:
    """The Python example number `index` of docs/name."""
    return str(re.findall(r"```python\n(.*?)```", (DOCS / name).read_text(), flags=re.S)[index])


def test_the_live_input_example_drives_a_session_and_stops(
    capsys: pytest.CaptureFixture[str],
) -> None:
    exec(compile(block("teleop.md"), "docs/teleop.md", "exec"), {})
    status, periods, drawn = capsys.readouterr().out.split()
    assert status == "ok"
    assert int(periods) == int(drawn) > 100  # 0.5 s of pushes at 1 ms a period, then stop


def test_the_objective_example_builds_a_qp_with_the_posture_objective() -> None:
    import rcmplan as rp

    scope: dict[str, object] = {}
    exec(compile(block("design.md"), "docs/design.md", "exec"), scope)
    assert isinstance(scope["qp"], rp.QpSolver)
    assert isinstance(scope["keep"], rp.Objective)


def test_the_own_procedure_example_runs_its_circle_between_the_shipped_phases(
    capsys: pytest.CaptureFixture[str],
) -> None:
    exec(compile(block("design.md", 2), "docs/design.md", "exec"), {})
    names, deviation = capsys.readouterr().out.rsplit(") ", 1)
    assert names == "('approach', 'align', 'insert', 'circle', 'retract', 'withdraw'"
    assert 0.0 < float(deviation) <= 0.8e-6  # within the controller's step bound


def test_the_own_solver_example_runs_the_injection_on_the_python_loop(
    capsys: pytest.CaptureFixture[str],
) -> None:
    exec(compile(block("design.md", 1), "docs/design.md", "exec"), {})
    records, deviation = capsys.readouterr().out.split()
    assert int(records) > 1465  # more iterations than pinv's full steps take
    assert 0.0 < float(deviation) <= 0.8e-6
