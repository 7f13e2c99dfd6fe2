"""The user's cache folder, where rcmplan keeps what it computes once per installation (the
compiled kernels' stamp, `rcmplan.compiled.cache`; parsed URDF chains, `rcmplan.robot.urdf`):
`$XDG_CACHE_HOME/rcmplan`, by default `~/.cache/rcmplan`."""

from __future__ import annotations

import os
from pathlib import Path


def cache_folder() -> Path:
    """rcmplan's folder in the user's cache (not created here)."""
    return Path(os.environ.get("XDG_CACHE_HOME") or "~/.cache").expanduser() / "rcmplan"
