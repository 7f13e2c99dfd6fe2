"""One comparison of two run logs, for the tests that hold the compiled path to the reference."""

from __future__ import annotations

import numpy as np

from rcmplan.control.log import ARRAY_FIELDS, RunLog


def assert_same_log(
    a: RunLog, b: RunLog, atol: float, nonempty: bool = False, joint_atol: float | None = None
) -> None:
    """Same length (and > 0 if `nonempty`), same NaN pattern, floats within `atol` (the
    joints and sliders within `joint_atol` if given), integers and names equal."""
    assert len(a) == len(b)
    assert len(a) > 0 or not nonempty
    for k in ARRAY_FIELDS:
        x, y = getattr(a, k), getattr(b, k)
        tol = joint_atol if joint_atol is not None and k in ("joints", "sliders") else atol
        if x.dtype.kind == "f":
            np.testing.assert_array_equal(np.isnan(x), np.isnan(y), err_msg=k)
            np.testing.assert_allclose(x, y, rtol=0, atol=tol, err_msg=k)
        else:
            np.testing.assert_array_equal(x, y, err_msg=k)
    assert a.phase_names == b.phase_names and a.solver_names == b.solver_names
