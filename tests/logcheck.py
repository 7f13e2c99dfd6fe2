"""One comparison of two run logs, for the tests that hold the compiled path to the reference."""

from __future__ import annotations

import numpy as np

from rcmplan.control.log import ARRAY_FIELDS, RunLog


def assert_same_log(a: RunLog, b: RunLog, atol: float, nonempty: bool = False) -> None:
    """Same length (and > 0 if `nonempty`), same NaN pattern, floats within `atol`, integers
    and names equal."""
    assert len(a) == len(b)
    assert len(a) > 0 or not nonempty
    for k in ARRAY_FIELDS:
        x, y = getattr(a, k), getattr(b, k)
        if x.dtype.kind == "f":
            np.testing.assert_array_equal(np.isnan(x), np.isnan(y), err_msg=k)
            np.testing.assert_allclose(x, y, rtol=0, atol=atol, err_msg=k)
        else:
            np.testing.assert_array_equal(x, y, err_msg=k)
    assert a.phase_names == b.phase_names and a.solver_names == b.solver_names
