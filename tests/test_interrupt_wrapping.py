"""An interrupt that Python wraps in another exception still stops the command as an interrupt."""

from __future__ import annotations

import pytest

from rcmplan.cli import interrupts


class _Hook:
    def __set_name__(self, owner: type, name: str) -> None:
        raise interrupts.Terminated()  # as if SIGTERM landed while a class body was created


def _make_class() -> type:
    return type("Plotting", (), {"hook": _Hook()})


def test_python_wraps_an_interrupt_raised_in_set_name() -> None:
    with pytest.raises(RuntimeError) as info:
        _make_class()
    assert isinstance(interrupts.wrapped_interrupt(info.value), interrupts.Terminated)


def test_surfaced_raises_the_wrapped_interrupt_itself() -> None:
    with pytest.raises(interrupts.Terminated), interrupts.surfaced():
        _make_class()


def test_surfaced_leaves_other_errors_alone() -> None:
    with pytest.raises(ValueError, match="plain"), interrupts.surfaced():
        raise ValueError("plain")


def test_an_interrupt_that_cut_an_extension_s_import_is_raised_as_the_interrupt(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import importlib

    from rcmplan.exceptions import MissingExtraError, require_extra

    def cut(name: str) -> None:  # pybind11's init turns a pending interrupt into ImportError
        try:
            raise interrupts.Interrupted()
        except KeyboardInterrupt as exc:
            raise ImportError("initialization failed") from exc

    monkeypatch.setattr(importlib, "import_module", cut)
    with pytest.raises(interrupts.Interrupted):
        require_extra("mujoco", "sim")

    def missing(name: str) -> None:
        raise ImportError(f"No module named {name!r}")

    monkeypatch.setattr(importlib, "import_module", missing)
    with pytest.raises(MissingExtraError, match="mujoco"):
        require_extra("mujoco", "sim")
