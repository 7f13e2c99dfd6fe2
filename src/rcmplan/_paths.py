"""The user's cache folder, where rcmplan keeps what it computes once and can compute again (the
compiled kernels' stamp, `rcmplan._kernel_cache`; parsed URDF chains, `rcmplan.robot.urdf`;
searched homes, `rcmplan.robot.robot_file`): `$XDG_CACHE_HOME/rcmplan`, by default
`~/.cache/rcmplan`. A result is kept as JSON in a file named by a hash of everything it
depends on; a file that cannot be read or written is passed over (the result is computed)."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
from pathlib import Path
from typing import Any

from rcmplan._atomic import write_text


def cache_folder() -> Path:
    """rcmplan's folder in the user's cache (not created here)."""
    return Path(os.environ.get("XDG_CACHE_HOME") or "~/.cache").expanduser() / "rcmplan"


def kept_file(kind: str, *parts: bytes) -> Path:
    """The file that keeps a result of this `kind` computed from `parts` (the bytes it depends
    on, each hashed apart so that no two lists of parts share a name)."""
    key = hashlib.sha256()
    for part in parts:
        key.update(hashlib.sha256(part).digest())
    return cache_folder() / kind / f"{key.hexdigest()[:32]}.json"


def read_kept(file: Path) -> Any:
    """The value kept in file, or None when there is none to read."""
    try:
        return json.loads(file.read_text())
    except (OSError, ValueError):
        return None


def keep(file: Path, value: Any) -> None:
    """Keep value (JSON) in file, written atomically; a folder that refuses is passed over."""
    with contextlib.suppress(OSError):
        file.parent.mkdir(parents=True, exist_ok=True)
        write_text(file, json.dumps(value))
