"""An interrupt that numba wraps (a signal landing in its dispatcher comes out as a SystemError
whose cause is the interrupt) still carries what the run recorded: `run_scenario` and a
teleoperation session raise the interrupt itself with their partial result."""

from __future__ import annotations

from typing import Any

import pytest

from rcmplan.cli import interrupts
from rcmplan.controller import Controller
from rcmplan.job import run_scenario
from rcmplan.scene.scenario import load_scenario
from rcmplan.teleop import SyntheticSurgeon, TeleopSettings, run_replay
from rcmplan.teleop.session import Session


def wrapped_stop() -> None:
    """Raise SIGTERM's interrupt as numba's dispatcher passes it on: inside a SystemError."""
    try:
        raise interrupts.Terminated()
    except interrupts.Terminated as cause:
        raise SystemError("a dispatcher returned a result with an exception set") from cause


def test_a_wrapped_interrupt_in_a_run_carries_its_records(monkeypatch: pytest.MonkeyPatch) -> None:
    run_phase, phases = Controller.run_phase, []

    def two_phases_then_stop(self: Controller, phase: Any) -> None:
        phases.append(phase.name)
        if len(phases) == 3:
            wrapped_stop()
        run_phase(self, phase)

    monkeypatch.setattr(Controller, "run_phase", two_phases_then_stop)
    with pytest.raises(interrupts.Terminated) as info:
        run_scenario(load_scenario("default"))
    result = info.value.result  # type: ignore[attr-defined]
    assert isinstance(info.value.__cause__, SystemError)
    assert result.status == "interrupted" and result.message == "interrupted by SIGTERM"
    assert len(result.log) > 0
    assert set(result.log.phase_names[i] for i in set(result.log.phase)) == set(phases[:2])


def test_a_wrapped_interrupt_in_a_session_carries_its_periods(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    period, calls = Session.period, []

    def stop_at_period_300(self: Session, sample: Any) -> Any:
        calls.append(1)
        if len(calls) == 300:
            wrapped_stop()
        return period(self, sample)

    monkeypatch.setattr(Session, "period", stop_at_period_300)
    track = SyntheticSurgeon(seed=1).track()
    with pytest.raises(interrupts.Terminated) as info:
        run_replay(TeleopSettings(), track)
    result = info.value.result  # type: ignore[attr-defined]
    assert isinstance(info.value.__cause__, SystemError)
    assert result.status == "interrupted" and result.message == "interrupted by SIGTERM"
    assert len(result.log) == 299  # the periods before the one the signal cut
