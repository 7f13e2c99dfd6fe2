"""`python -m rcmplan.compiled.warm`: compile every kernel into numba's cache, then stamp it.

Started in the background by the "auto" mode of `fast_cache` when the cache is cold; safe to run
by hand (for example in a container build) so that the first large job starts compiled.
"""

from rcmplan.compiled.cache import compile_all

if __name__ == "__main__":
    print(compile_all())
