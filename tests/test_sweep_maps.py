"""Sweep maps: every gain candidate labelled, coinciding candidates sharing one label."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from rcmplan.sweep.maps import label_candidates


class Recorder:
    def __init__(self) -> None:
        self.labels: list[str] = []

    def annotate(self, text: str, *args: object, **kwargs: object) -> None:
        self.labels.append(text)


def candidate(k_task: float, k_rcm: float, step_m: float) -> SimpleNamespace:
    return SimpleNamespace(candidate=SimpleNamespace(k_task=k_task, k_rcm=k_rcm,
                                                     step_position=step_m))  # fmt: skip


def test_candidates_on_the_same_point_share_one_label_naming_each() -> None:
    ax = Recorder()
    ev = [candidate(1.0, 0.7, 2e-4), candidate(1.0, 1.3, 2e-4), candidate(1.0, 1.0, 5e-4)]
    label_candidates(ax, ev, np.array([0.6, 0.6, 3.6]), np.array([660.0, 661.0, 220.0]))
    assert ax.labels == ["1/0.7/0.2\n1/1.3/0.2", "1/1/0.5"]
