"""The shipped arms by name: their robot files (`rcmplan/robots/*.toml`) read into model
files, flange frames, chains and needle-holding arms."""

from __future__ import annotations

from pathlib import Path

from rcmplan.robot.chain import JointChain
from rcmplan.robot.library import shipped_robot_file
from rcmplan.robot.model import SerialArm
from rcmplan.robot.robot_file import load_robot_file, model_chain, model_path, read_robot_file


def robot_file(name: str) -> Path:
    """The model file (URDF) of a shipped arm (one of ROBOT_FILES)."""
    return model_path(read_robot_file(shipped_robot_file(name)))


def flange_frame(name: str) -> str:
    """The link a shipped arm's chain ends at (its flange), one of ROBOT_FILES."""
    return read_robot_file(shipped_robot_file(name)).flange


def robot_chain(name: str) -> JointChain:
    """A shipped arm's chain from its URDF root to its flange frame."""
    return model_chain(read_robot_file(shipped_robot_file(name)))


def ur5_chain() -> JointChain:
    """The UR5 from `base_link` (z up, at the URDF root) to `tool0` (z = wrist 3 axis)."""
    return robot_chain("ur5")


def panda_chain() -> JointChain:
    """The Franka Panda from `panda_link0` to the flange `panda_link8` (z = joint 7 axis)."""
    return robot_chain("panda")


def shipped_arm(name: str) -> SerialArm:
    """A shipped arm (one of `rcmplan.robot.library.ROBOT_FILES`) from its robot file."""
    return load_robot_file(shipped_robot_file(name)).arm
