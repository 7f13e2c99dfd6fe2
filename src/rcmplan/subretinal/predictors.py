"""The predictors by name: `none`, `hold`, `fft` (`predict.py`) and rcmplan's `kalman`
(`kalman.py`), each behind `update(t_acq, value)` / `predict(t)`."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rcmplan.exceptions import InvalidInputError
from rcmplan.subretinal.kalman import KalmanPredictor
from rcmplan.subretinal.predict import FftPredictor, HoldPredictor, NonePredictor, Predictor

PREDICTORS: dict[str, Callable[..., Predictor]] = {
    "none": NonePredictor,
    "hold": HoldPredictor,
    "fft": FftPredictor,
    "kalman": KalmanPredictor,
}


def make_predictor(name: str, **kwargs: Any) -> Predictor:
    """A new predictor by name (`PREDICTORS`), with its keyword arguments."""
    if name not in PREDICTORS:
        raise InvalidInputError("predictor", name, "one of " + ", ".join(PREDICTORS))
    return PREDICTORS[name](**kwargs)
