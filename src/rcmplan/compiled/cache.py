"""Where the compiled code lives, and when numba's cache of it is stale.

There is one path: every phase that a kernel implements runs compiled, from the first target
on, in every process. numba compiles each kernel when it is first called with a set of argument
types and keeps it in its cache (`cache=True`, under `__pycache__` beside the source, or
`NUMBA_CACHE_DIR`), so the first run of each kind after an install or an upgrade compiles (a
run that compiles says so on stderr, once: `rcmplan._jit.FirstCompile`; stale kernels are
cleared from numba's cache before the first is compiled or loaded: `rcmplan._kernel_cache`).
Nothing here starts a process or reads an environment variable of rcmplan's own.
"""

from __future__ import annotations

import importlib
import importlib.util
from types import ModuleType
from typing import Any

from rcmplan.exceptions import require_extra

_state: dict[str, Any] = {"daqp_abi": None}


def _load(name: str) -> ModuleType:
    """Import a module of compiled code."""
    return importlib.import_module(f"rcmplan.compiled.{name}")


def kernels() -> ModuleType:
    """The iRAM!S kinematics kernels (`kernels`)."""
    return _load("kernels")


def chain_kernels() -> ModuleType:
    """The kinematics kernels of any serial arm (`chain_kernels`)."""
    return _load("chain_kernels")


def algorithm() -> ModuleType:
    """Algorithm 1's loop over a phase, for every robot and both plants (`algorithm`)."""
    return _load("algorithm")


def arm_loop() -> ModuleType:
    """Algorithm 1 for a serial arm compiled (`arm_loop`)."""
    return _load("arm_loop")


def arm_qp_kernels() -> ModuleType:
    """The QP step's kernels for a serial arm (`arm_qp_kernels`)."""
    return _load("arm_qp_kernels")


def loop_kernels() -> ModuleType:
    """The compiled control loop (`loop`)."""
    return _load("loop")


def qp_kernels() -> ModuleType:
    """The QP step's kernels (`qp_kernels`: assembly and DAQP's C solve)."""
    return _load("qp_kernels")


def daqp_callable() -> bool:
    """True if DAQP's C solver can be called from compiled code here (`daqp_c.abi_ok`: False
    for a DAQP version whose structures are not the ones copied); checked once per process."""
    if _state["daqp_abi"] is None:
        _state["daqp_abi"] = _load("daqp_c").abi_ok()
    return bool(_state["daqp_abi"])


def qp_loop() -> ModuleType | None:
    """The compiled control loop (`loop`) where it can run the QP, or None if DAQP's C solver
    cannot be called from compiled code here (`daqp_callable`)."""
    return _load("loop") if daqp_callable() else None


def qp_periods() -> ModuleType | None:
    """The compiled block of control periods of the QP controller (`qp_periods`), or None if
    DAQP's C solver cannot be called from compiled code here (`daqp_callable`)."""
    return _load("qp_periods") if daqp_callable() else None


def closed_loop() -> ModuleType:
    """The compiled loop around the dynamic MuJoCo plant (`mujoco_loop`); needs MuJoCo
    (MissingExtraError naming the `sim` extra otherwise)."""
    require_extra("mujoco", "sim")
    return _load("mujoco_loop")
