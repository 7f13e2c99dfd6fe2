"""Teleoperation: a surgeon's hand through clutch, motion scaling and tremor filtering to the
needle, with virtual fixtures held by the QP at every 1 kHz period (docs/teleop.md).

Inputs: a replay file (`read_track`), the seeded `SyntheticSurgeon`, or `LiveInput` fed by any
device from its own thread. `run_replay` runs a track as fast as possible; `run_live` paces a
live input at wall-clock time until a stop event is set.
"""

from rcmplan.teleop.filters import FILTERS, LowPassFilter, NoFilter
from rcmplan.teleop.fixtures import Fixtures
from rcmplan.teleop.live import LiveInput
from rcmplan.teleop.replay import read_track, write_track
from rcmplan.teleop.run import TeleopResult, run_live, run_replay
from rcmplan.teleop.samples import MasterSample, MasterTrack
from rcmplan.teleop.session import TeleopState
from rcmplan.teleop.settings import TeleopSettings
from rcmplan.teleop.synthetic import SyntheticSurgeon
from rcmplan.teleop.wflc import WflcFilter

__all__ = [
    "FILTERS",
    "Fixtures",
    "LiveInput",
    "LowPassFilter",
    "MasterSample",
    "MasterTrack",
    "NoFilter",
    "SyntheticSurgeon",
    "TeleopResult",
    "TeleopSettings",
    "TeleopState",
    "WflcFilter",
    "read_track",
    "run_live",
    "run_replay",
    "write_track",
]
