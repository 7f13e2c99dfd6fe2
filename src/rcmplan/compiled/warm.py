"""`python -m rcmplan.compiled.warm`: compile every kernel into numba's cache, then stamp it.

Started in the background by the "auto" mode of `rcmplan.compiled.cache` when the cache is
cold; safe to run by hand (for example in a container build) so that the first large job starts
compiled.
"""

from __future__ import annotations

from pathlib import Path

from rcmplan.compiled.cache import stamp_path
from rcmplan.compiled.curved_phase import compile_curved_kernels
from rcmplan.compiled.runner import compile_kernels


def compile_all() -> Path:
    """Compile every kernel (numba writes them to its cache), then write the stamp."""
    compile_kernels()
    compile_curved_kernels()
    path = stamp_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("numba cache of rcmplan.compiled kernels and loops is warm\n")
    return path


if __name__ == "__main__":
    print(compile_all())
