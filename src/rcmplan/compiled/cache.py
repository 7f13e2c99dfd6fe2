"""Where the compiled code lives, and when numba's cache of it is stale.

There is one path: every phase that a kernel implements runs compiled, from the first target
on, in every process. numba compiles each kernel when it is first called with a set of argument
types and keeps it in its cache (`cache=True`, under `__pycache__` beside the source, or
`NUMBA_CACHE_DIR`), so the first run of each kind after an install or an upgrade compiles (a
run that compiles says so on stderr, once: `rcmplan._jit.FirstCompile`).
Nothing here starts a process or reads an environment variable of rcmplan's own.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import importlib.util
import os
import sys
from importlib import metadata
from pathlib import Path
from types import ModuleType
from typing import Any

from rcmplan._paths import cache_folder
from rcmplan.exceptions import require_extra

_state: dict[str, Any] = {"noticed": False, "daqp_abi": None}


def _load(name: str) -> ModuleType:
    """Import a module of compiled code, first (once per process) clearing numba's cache of
    rcmplan's kernels if this installation's stamp is new (`clear_stale`)."""
    if not _state["noticed"]:
        _state["noticed"] = True
        stamp = stamp_path()
        if not stamp.exists():
            try:
                stamp.parent.mkdir(parents=True, exist_ok=True)
                writable = os.access(stamp.parent, os.W_OK)
            except OSError:
                writable = False
            # Without a stamp nothing would record the clearing: every run would clear and
            # compile again (a read-only cache folder: numba's cache, checked against each
            # kernel's own file, is kept)
            if writable:
                clear_stale()
                with contextlib.suppress(OSError):
                    stamp.write_text("numba compiled rcmplan's kernels in this installation\n")
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


def clear_stale() -> None:
    """Remove rcmplan's kernels from numba's cache (NUMBA_CACHE_DIR when set, else the
    package's __pycache__ folders). numba checks a cached function against its own file only;
    a kernel whose callee moved or changed in another file would load stale code (or fail to
    load). The stamp changes with any kernel source, so a new stamp clears them."""
    package = Path(__file__).parent.parent
    custom = os.environ.get("NUMBA_CACHE_DIR")
    if custom:  # numba's cache of this process: the folder it keeps for each kernel's folder
        try:  # numba's own naming of those folders (a private helper of numba.core.caching)
            from numba.core.caching import _CacheLocator

            locate = _CacheLocator.get_suitable_cache_subpath
        except (ImportError, AttributeError):  # a numba without it: nothing found to clear
            return
        folders = [Path(custom) / sub for sub in sorted({locate(p) for p in kernel_sources()})]
    else:
        folders = [*package.rglob("__pycache__")]
    for folder in folders:
        for path in [*folder.glob("*.nbi"), *folder.glob("*.nbc")]:
            with contextlib.suppress(OSError):  # another process removed it first
                path.unlink()


def kernel_sources() -> list[Path]:
    """The files that hold rcmplan's numba kernels (a test keeps the list whole): this folder,
    the decorator they are compiled with (`_jit`), the step solves (`linalg`), the robot
    kernels (the curved needle's included), the control kernels (the step bound, the cost, the
    limited step, the curved needle's steps, DLS's task, a command's rounding to the actuator
    resolution, the limits' rows), the compiled MuJoCo plant and its actuators' velocity
    profile, and the iOCT B-scan's rendering and segmentation."""
    package = Path(__file__).parent.parent
    robot, control, subretinal = package / "robot", package / "control", package / "subretinal"
    return [
        *sorted(Path(__file__).parent.glob("*.py")),
        package / "_jit.py",
        package / "linalg.py",
        *(robot / f"{m}.py" for m in ("iramis_kernels", "chain_kinematics", "chain_singular",
                                       "chain_pose", "needle", "curved_block", "curved_iramis",
                                       "curved_arm")),
        *(control / f"{m}.py" for m in ("rcm_step", "cost", "limited_tip", "curved_step",
                                        "dls_task", "resolution")),
        *sorted((control / "limits").glob("*.py")),
        *(package / "sim" / "mujoco" / f"{m}.py" for m in ("compiled", "actuators")),
        *(subretinal / f"{m}.py" for m in ("ioct", "segment_filters", "segment_kernels")),
    ]  # fmt: skip


def stamp_path() -> Path:
    """The file that records that this installation's kernels were compiled once (keyed by
    their source, numba, Python and the cache folder)."""
    here = Path(__file__).parent
    key = hashlib.sha256()
    for path in kernel_sources():
        key.update(path.read_bytes())
    key.update(metadata.version("numba").encode())
    key.update(sys.version.encode())
    key.update(os.environ.get("NUMBA_CACHE_DIR", "").encode())
    key.update(str(here).encode())
    return cache_folder() / f"compiled-{key.hexdigest()[:16]}.ok"
