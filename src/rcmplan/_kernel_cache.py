"""numba's cache of rcmplan's kernels, checked once per process before the first kernel is
compiled or loaded (`rcmplan._jit` calls `check_once` as it is imported, before any kernel
module defines its kernels).

numba checks a cached kernel against its own file only: a kernel whose callee moved or changed
in another file would load stale code (or fail to load): a loop compiled with another version's
work-array layout writes past the arrays it is given. So a stamp under the user's cache folder
(`$XDG_CACHE_HOME/rcmplan`), one per numba cache (the installation's place and
NUMBA_CACHE_DIR), holds the key of the kernels that cache was last cleared for (every file
holding a kernel, numba's and Python's versions); a stamp missing or holding another key (an
install, an upgrade, an edit, and as much a downgrade or an edit undone) first clears them
(`clear_stale`). Where the stamp cannot be written nothing is cleared: without a stamp to
record it, every run would clear and compile again.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import sys
from importlib import metadata
from pathlib import Path

from rcmplan._paths import cache_folder

_checked = [False]


def check_once() -> None:
    """Clear rcmplan's kernels from numba's cache unless the stamp says it was last cleared for
    these kernels (once per process)."""
    if _checked[0]:
        return
    _checked[0] = True
    stamp, key = stamp_path(), stamp_key()
    with contextlib.suppress(OSError, UnicodeDecodeError):
        if stamp.read_text().strip() == key:
            return
    try:
        stamp.parent.mkdir(parents=True, exist_ok=True)
        writable = os.access(stamp.parent, os.W_OK)
    except OSError:
        writable = False
    if writable:
        clear_stale()
        with contextlib.suppress(OSError):
            stamp.write_text(key + "\n")


def clear_stale() -> None:
    """Remove rcmplan's kernels from numba's cache (NUMBA_CACHE_DIR when set, else the
    package's __pycache__ folders). numba checks a cached function against its own file only;
    a kernel whose callee moved or changed in another file would load stale code (or fail to
    load). The stamp changes with any kernel source, so a new stamp clears them."""
    package = Path(__file__).parent
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
    """The files that hold rcmplan's numba kernels (a test keeps the list whole): `compiled/`,
    the decorator they are compiled with (`_jit`), the step solves (`linalg`), the robot
    kernels (the curved needle's included), the control kernels (the step bound, the cost, the
    limited step, the curved needle's steps, DLS's task, a command's rounding to the actuator
    resolution, the limits' rows), the compiled MuJoCo plant and its actuators' velocity
    profile, and the iOCT B-scan's rendering and segmentation."""
    package = Path(__file__).parent
    robot, control, subretinal = package / "robot", package / "control", package / "subretinal"
    return [
        *sorted((package / "compiled").glob("*.py")),
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
    """The file that holds the key of the kernels this installation's numba cache was last
    cleared for (`stamp_key`): one per cache, keyed by the installation's place and
    NUMBA_CACHE_DIR."""
    here = Path(__file__).parent  # the installation's place
    place = hashlib.sha256(f"{here}\0{os.environ.get('NUMBA_CACHE_DIR', '')}".encode())
    return cache_folder() / f"compiled-{place.hexdigest()[:16]}.stamp"


def stamp_key() -> str:
    """The key of this installation's kernels: every file holding one, numba's and Python's
    versions."""
    key = hashlib.sha256()
    for path in kernel_sources():
        key.update(path.read_bytes())
    key.update(metadata.version("numba").encode())
    key.update(sys.version.encode())
    return key.hexdigest()
