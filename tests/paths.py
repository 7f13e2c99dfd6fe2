"""Choosing the code that runs a phase, for tests that compare the compiled runner with the
Python loop: `use_path("off")` registers the reference runner as the default (every phase in
Python), `use_path("on")` or `use_path(None)` the compiled runner again."""

from __future__ import annotations

from rcmplan.control.runner import ReferenceRunner, register_default


def use_path(mode: str | None) -> None:
    """ "off": the Python loop runs every phase; "on" or None: the compiled runner, where it
    applies (the default)."""
    if mode not in ("on", "off", None):
        raise ValueError(f"mode {mode!r}: 'on', 'off' or None")
    register_default(ReferenceRunner() if mode == "off" else None)
