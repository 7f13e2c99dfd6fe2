"""Controllers built with other libraries on rcmplan's tasks, for the benchmarks to compare with.

Each needs its library (the `bench` extra); importing a module here without it raises
ImportError, which the benchmark reports as a skipped peer.
"""
