"""numba's cache of rcmplan's kernels, checked once per process before the first kernel is
compiled or loaded (`rcmplan._jit` calls `check_once` as it is imported, before any kernel
module defines its kernels).

numba checks a cached kernel against its own file only: a kernel whose callee moved or changed
in another file would load stale code (or fail to load). So a stamp under the user's cache
folder (`$XDG_CACHE_HOME/rcmplan`, keyed by every file holding a kernel, numba's and Python's
versions and the cache folder) records that this installation's kernels were cleared once; a
new stamp (an install, an upgrade, an edit) first clears them (`clear_stale`). Where the stamp
cannot be written nothing is cleared: without a stamp to record it, every run would clear and
compile again.
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
    """Clear rcmplan's kernels from numba's cache if this installation's stamp is new (once per
    process)."""
    if _checked[0]:
        return
    _checked[0] = True
    stamp = stamp_path()
    if stamp.exists():
        return
    try:
        stamp.parent.mkdir(parents=True, exist_ok=True)
        writable = os.access(stamp.parent, os.W_OK)
    except OSError:
        writable = False
    if writable:
        clear_stale()
        with contextlib.suppress(OSError):
            stamp.write_text("numba's cache of rcmplan's kernels cleared for this installation\n")


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
    """The file that records that numba's cache was cleared of this installation's stale
    kernels (keyed by their sources, numba, Python, the cache folder and the installation's
    place)."""
    here = Path(__file__).parent  # the installation's place
    key = hashlib.sha256()
    for path in kernel_sources():
        key.update(path.read_bytes())
    key.update(metadata.version("numba").encode())
    key.update(sys.version.encode())
    key.update(os.environ.get("NUMBA_CACHE_DIR", "").encode())
    key.update(str(here).encode())
    return cache_folder() / f"compiled-{key.hexdigest()[:16]}.ok"
