"""Compiled kernels and the compiled runner (numba, the `fast` extra), above `control/` and
`sim/`: importing this package makes the compiled runner the controller's default runner.
Nothing here imports numba until a kernel is first needed (see `cache`)."""

from rcmplan.compiled.runner import CompiledRunner
from rcmplan.control.runner import register_default

register_default(CompiledRunner())

__all__ = ["CompiledRunner"]
