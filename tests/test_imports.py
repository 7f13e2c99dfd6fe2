"""Every module of the package imports (a stale import path fails here, not in a user's run)."""

from __future__ import annotations

import importlib
import pkgutil

import pytest

import rcmplan

ENTRY_POINTS = ("rcmplan.__main__", "rcmplan.compiled.warm")  # run on import: not imported here
MODULES = sorted(
    m.name
    for m in pkgutil.walk_packages(rcmplan.__path__, "rcmplan.")
    if m.name not in ENTRY_POINTS
)


def test_the_package_has_its_layers() -> None:
    for layer in ("robot", "control", "compiled", "scene", "sim", "analysis", "sweep", "cli"):
        assert f"rcmplan.{layer}" in MODULES


@pytest.mark.parametrize("name", MODULES)
def test_every_module_imports(name: str) -> None:
    assert importlib.import_module(name).__name__ == name
