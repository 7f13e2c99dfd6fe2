"""Every module of the package imports (a stale import path fails here, not in a user's run)."""

from __future__ import annotations

import importlib
import pkgutil

import pytest

import rcmplan

ENTRY_POINTS = ("rcmplan.__main__",)  # run on import: not imported here
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


def test_the_command_line_starts_without_the_heavy_optional_modules() -> None:
    """The full parser (`rcmplan --help`, an unknown command) registers every command: none may
    import a heavy optional module at start-up (each costs 0.1-1.2 s on every run); they load
    when a command needs them."""
    import subprocess
    import sys

    heavy = ["scipy.signal", "viser", "matplotlib", "dask", "mujoco", "playwright", "dqrobotics"]
    code = (
        "import sys, rcmplan.cli as c; c.build_parser(); "
        f"print([m for m in {heavy!r} if m in sys.modules])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_the_viewer_loads_the_subretinal_models_only_for_an_episode() -> None:
    """`rcmplan view RUN` imports the replay for every run: the B-scan panel's iOCT models (and
    the motion model's scipy.signal, 2 s with scipy.stats) load only with an episode's
    B-scans (`run_folder`)."""
    import subprocess
    import sys

    code = (
        "import sys, rcmplan.view.replay; "
        "print([m for m in ('scipy.signal', 'rcmplan.subretinal.episode_ioct') if m in sys.modules])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_every_name_the_package_exports_resolves() -> None:
    for name in rcmplan.__all__:
        assert getattr(rcmplan, name) is not None, name


def test_importing_the_package_loads_no_numerical_library() -> None:
    """`import rcmplan` is cheap: its names load on first use (numba, scipy, the models)."""
    import subprocess
    import sys

    code = "import sys, rcmplan; print([m for m in ('numba', 'scipy', 'rcmplan.control') if m in sys.modules])"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout
