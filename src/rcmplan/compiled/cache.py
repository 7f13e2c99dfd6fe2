"""When the compiled path runs, and where its compiled code is cached.

Modes (environment variable RCMPLAN_FAST, or `set_mode`):
- "off": never; the reference Python code runs.
- "on": whenever numba is installed; kernels compile on first use (about 10 s once per
  environment; numba's cache, `cache=True`, keeps them for later processes).
- "auto" (default): compiled once it pays. Loading numba and the cached kernels costs about
  1.2 s per process, as much as about 3,000 targets of the reference loop, so a process first
  runs the reference code; once it has run PAYOFF_TARGETS targets (or is about to run a phase
  that large) it switches to the compiled code if numba's cache is warm. With a cold cache it
  keeps the reference code and starts one background process that compiles the kernels into the
  cache (`python -m rcmplan.compiled.warm`); a stamp file marks the cache warm when done.
  Kernels already loaded in the process are always used. See docs/performance.md for figures.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import importlib.util
import os
import subprocess
import sys
from collections.abc import Iterator
from importlib import metadata
from pathlib import Path
from types import ModuleType
from typing import Any

from rcmplan.exceptions import InvalidInputError, require_extra

MODES = ("auto", "on", "off")
ENV_MODE = "RCMPLAN_FAST"
ENV_STAMPS = "RCMPLAN_CACHE_DIR"
PAYOFF_TARGETS = 3000
_state: dict[str, Any] = {"mode": None, "warming": None, "reference_targets": 0}


def set_mode(mode: str | None) -> None:
    """Choose "auto", "on" or "off"; None goes back to the environment (default "auto")."""
    if mode is not None and mode not in MODES:
        raise InvalidInputError("fast mode", mode, f"one of {MODES}")
    _state["mode"] = mode


def mode() -> str:
    """The mode in force."""
    chosen = _state["mode"] or os.environ.get(ENV_MODE, "auto")
    if chosen not in MODES:
        raise InvalidInputError(ENV_MODE, chosen, f"one of {MODES}")
    return str(chosen)


def numba_available() -> bool:
    """True if numba is installed (without importing it)."""
    return importlib.util.find_spec("numba") is not None


def kernels() -> ModuleType:
    """The kinematics kernels (`kernels`); MissingExtraError without numba."""
    require_extra("numba", "fast")
    return importlib.import_module("rcmplan.compiled.kernels")


def chain_kernels() -> ModuleType:
    """The kinematics kernels of any serial arm (`chain_kernels`); MissingExtraError without
    numba."""
    require_extra("numba", "fast")
    return importlib.import_module("rcmplan.compiled.chain_kernels")


def arm_loop() -> ModuleType:
    """Algorithm 1 for a serial arm compiled, one iteration or a whole phase on a plant with
    exact commands (`arm_loop`); MissingExtraError without numba."""
    require_extra("numba", "fast")
    return importlib.import_module("rcmplan.compiled.arm_loop")


def loop_kernels() -> ModuleType:
    """The compiled control loop (`loop`); MissingExtraError without numba."""
    require_extra("numba", "fast")
    return importlib.import_module("rcmplan.compiled.loop")


def qp_kernels() -> ModuleType:
    """The QP step's kernels (`qp_kernels`: assembly and DAQP's C solve); MissingExtraError
    without numba or DAQP."""
    require_extra("numba", "fast")
    require_extra("daqp", "qp")
    return importlib.import_module("rcmplan.compiled.qp_kernels")


def qp_loop() -> ModuleType | None:
    """The compiled QP loop (`qp_loop`), or None if DAQP's C solver cannot be called from
    compiled code here (`daqp_c.abi_ok`: a DAQP version whose structures are not the ones
    copied, or no DAQP at all: the reference path then raises MissingExtraError at its first
    solve); checked once per process. MissingExtraError without numba."""
    require_extra("numba", "fast")
    if importlib.util.find_spec("daqp") is None:
        return None
    if _state.get("daqp_abi") is None:
        _state["daqp_abi"] = importlib.import_module("rcmplan.compiled.daqp_c").abi_ok()
    if not _state["daqp_abi"]:
        return None
    return importlib.import_module("rcmplan.compiled.qp_loop")


def closed_loop() -> ModuleType:
    """The compiled loop around the dynamic MuJoCo plant (`mujoco_loop`); needs numba and
    MuJoCo (MissingExtraError naming the extra otherwise)."""
    require_extra("numba", "fast")
    require_extra("mujoco", "sim")
    return importlib.import_module("rcmplan.compiled.mujoco_loop")


def stamp_path() -> Path:
    """The file that marks numba's cache as holding every kernel of this source and numba."""
    here = Path(__file__).parent
    key = hashlib.sha256()
    kernels = ("kernels", "chain_kinematics", "chain_solve", "chain_checks", "arm_loop", "loop",
               "mujoco_loop", "daqp_c", "qp_params", "qp_kernels", "qp_loop")  # fmt: skip
    files = [here / f"{name}.py" for name in kernels]
    for path in (*files, here.parent / "sim" / "mujoco" / "compiled.py"):
        key.update(path.read_bytes())
    key.update(metadata.version("numba").encode())
    key.update(sys.version.encode())
    key.update(os.environ.get("NUMBA_CACHE_DIR", "").encode())
    key.update(str(here).encode())
    base = os.environ.get(ENV_STAMPS) or os.environ.get("XDG_CACHE_HOME") or "~/.cache"
    return Path(base).expanduser() / "rcmplan" / f"fast-{key.hexdigest()[:16]}.ok"


def loaded() -> bool:
    """True if the compiled loop is loaded in this process (compiled or read from the cache)."""
    loop = sys.modules.get("rcmplan.compiled.loop")
    return loop is not None and bool(loop.run_targets.signatures)


def use_fast(n_targets: int = 0) -> bool:
    """Whether the compiled path runs now for a job of n_targets (see the module docstring)."""
    chosen = mode()
    if chosen == "off" or not numba_available():
        return False
    if chosen == "on" or loaded():
        return True
    _state["reference_targets"] += n_targets
    if _state["reference_targets"] < PAYOFF_TARGETS:
        return False
    if stamp_path().exists():
        return True
    warm_in_background()
    return False


def expect(n_targets: int) -> None:
    """Count work a job is about to do towards the payoff of mode "auto" (see `use_fast`)."""
    _state["reference_targets"] += n_targets


@contextlib.contextmanager
def pinned() -> Iterator[str]:
    """Run a block on one path only: compiled if numba is installed and the mode is not "off",
    else the reference code. Large jobs whose results must not depend on which process ran
    them (sweeps) use it: the two paths agree to about 1e-14, not to the last bit."""
    previous = _state["mode"]
    chosen = "on" if mode() != "off" and numba_available() else "off"
    _state["mode"] = chosen
    try:
        yield chosen
    finally:
        _state["mode"] = previous


def warm_in_background() -> None:
    """Start, once per process, `python -m rcmplan.compiled.warm` to fill the cache."""
    if _state["warming"] is not None:
        return
    _state["warming"] = subprocess.Popen(
        [sys.executable, "-m", "rcmplan.compiled.warm"],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
