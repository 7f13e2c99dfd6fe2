"""The compiled runner and its kernels: every phase a kernel implements runs here, called by
the controller (`rcmplan.controller`) through its runner seam (`rcmplan.control.runner`).
Nothing here imports a kernel module until a kernel is first needed (`cache`)."""

from rcmplan.compiled.runner import CompiledRunner

__all__ = ["CompiledRunner"]
