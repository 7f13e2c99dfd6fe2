"""Workspace sweeps: retina targets through the trocar, accuracy maps and gain search, run on
local processes or a Dask cluster, checkpointed as results arrive.

The gain search is in rcmplan.sweep.gains (it imports scipy.optimize), the figures in
rcmplan.sweep.maps (matplotlib)."""

from rcmplan.sweep.checkpoint import Checkpoint
from rcmplan.sweep.errors import CheckpointError, EmptyRegionError, SchedulerError
from rcmplan.sweep.executors import DaskExecutor, LocalExecutor, make_executor
from rcmplan.sweep.runner import SweepResult, run_sweep
from rcmplan.sweep.sampling import Sample, sample_region
from rcmplan.sweep.settings import MotionSettings, Region, SweepSettings
from rcmplan.sweep.task import TargetResult, run_target

__all__ = [
    "Checkpoint",
    "CheckpointError",
    "DaskExecutor",
    "EmptyRegionError",
    "LocalExecutor",
    "MotionSettings",
    "Region",
    "Sample",
    "SchedulerError",
    "SweepResult",
    "SweepSettings",
    "TargetResult",
    "make_executor",
    "run_sweep",
    "run_target",
    "sample_region",
]
