"""The iRAM!S robot in MuJoCo: MJCF generated from the DH model, a plant, piezo actuators, renders.

Importing this package selects headless EGL rendering (MUJOCO_GL=egl) on Linux when no
display is set and MUJOCO_GL is unset; MuJoCo reads the variable when it is first imported.
The plant and renderer import MuJoCo lazily and raise MissingExtraError (extra `sim`) without it.
"""

import os
import sys

if sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")
