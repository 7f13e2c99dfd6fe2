"""Shared fixtures: the default robot and a seeded random generator."""

from __future__ import annotations

import numpy as np
import pytest

from rcmplan import Iramis


@pytest.fixture
def robot() -> Iramis:
    return Iramis()


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20180507)


def random_joints(rng: np.random.Generator, n: int, angle: float = 1.2) -> np.ndarray:
    """n random joint vectors: prismatic in +-30 mm, revolute in +-angle rad."""
    q = rng.uniform(-1.0, 1.0, size=(n, 6))
    q[:, [0, 2, 4]] *= 0.03
    q[:, [1, 3, 5]] *= angle
    return q
