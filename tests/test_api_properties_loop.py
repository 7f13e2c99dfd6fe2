"""Generated inputs to phases, the controller and its run log (the rule: tests/api_inputs.py):
a typed error naming the argument, or a finite result within bounds."""

from __future__ import annotations

from typing import Any

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

import rcmplan as rp

from api_inputs import FOLDER, JUNK, Arg, choice, examples, finite, one_bad, probe, vector

ROBOT = rp.Iramis()
UR5 = rp.make_robot("ur5")
EYE = rp.default_eye(ROBOT)
INSERT = rp.injection(ROBOT, EYE, rp.default_points(EYE))[2].targets  # (N, 6) X_ext targets
TIP = ROBOT.tip(ROBOT.home)
SOLVERS = [rp.PinvSolver(), rp.TipSolver()]
LOG = rp.Controller(rp.KinematicPlant(ROBOT), rp.PinvSolver()).run(
    [rp.Phase("move", np.array([TIP + [1e-4, 0, 0], TIP + [2e-4, 0, 0]]), "free")]
)
joints = Arg(
    st.lists(st.floats(-0.01, 0.01), min_size=6, max_size=6).map(np.array),
    vector(6, -0.5, 0.5).bad,
)


phase_targets = Arg(
    st.sampled_from([INSERT[:3], INSERT[:3].tolist(), lambda q: INSERT[:2]]),
    st.one_of(st.sampled_from([np.zeros((0, 6)), np.array([TIP]), lambda q: "x", lambda q: INSERT[:, :4],
                               np.full((2, 6), np.nan)]), vector(6, -0.1, 0.1).any(), JUNK),
)  # fmt: skip


def planned(targets: Any) -> bool:
    return targets.ndim == 2 and targets.shape[1] == 6 and len(targets) >= 1 and finite(targets)


@examples(200)
@given(args=one_bad(Arg(st.text(max_size=5), JUNK), phase_targets, choice(["rcm"], ["free", "x"]),
                    joints))  # fmt: skip
def test_phases_are_planned_or_refused(args: tuple[Any, ...]) -> None:
    name, targets, kind, q = args
    phase = probe("Phase", rp.Phase, name, targets, kind, names=("name", "targets", "kind"),
                  ok=lambda p: callable(p.targets) or finite(p.targets))  # fmt: skip
    if phase is not None:
        probe("Phase.plan", phase.plan, q, ok=planned, names=("q", "targets"))


CONTROLLER = ("plant", "solver", "free_solver", "settings", "runner", "robot")
MOVE = [rp.Phase("move", np.array([TIP + [5e-5, 0, 0]]), "free")]


@examples(100)
@given(args=one_bad(
    choice(["kinematic"], [None, "plant"]), choice([SOLVERS[0]], [None, "pinv"]),
    choice([None, SOLVERS[1]], ["tip"]), choice([None, rp.LoopSettings()], [{}]),
    choice([None], ["compiled"]), choice([None, ROBOT], [UR5, "iramis"]),
    Arg(st.just(MOVE), st.one_of(st.sampled_from([[], ["x"], [rp.Phase("far", INSERT[-1:])]]), JUNK)),
))  # fmt: skip
def test_controllers_are_built_and_run_or_refused(args: tuple[Any, ...]) -> None:
    plant, *rest, phases = args
    if plant == "kinematic":
        plant = rp.KinematicPlant(ROBOT)
    controller = probe("Controller", rp.Controller, plant, *rest, names=CONTROLLER)
    if controller is not None:
        probe("Controller.run", controller.run, phases, names=("phases",),
              ok=lambda log: len(log) >= min(1, len(phases)) and np.isfinite(log.max_rcm_deviation()))  # fmt: skip


masks = Arg(
    st.one_of(st.lists(st.booleans(), min_size=len(LOG), max_size=len(LOG)),
              st.just(np.ones(len(LOG), bool))),
    st.one_of(st.lists(st.booleans(), max_size=1), JUNK, st.lists(st.integers(-3, 3), max_size=3)),
)  # fmt: skip
LOG_FIELDS = {k: getattr(LOG, k) for k in LOG.__dataclass_fields__}
NPZ = str(FOLDER / "log.npz")
LOG.save_npz(NPZ)


@examples(150)
@given(mask=masks.any(), field=st.sampled_from(["time", "tip", "step", "phase_names"]),
       value=st.one_of(JUNK, vector(3, 0, 1).any()))  # fmt: skip
def test_run_logs_are_selected_or_refused(mask: Any, field: str, value: Any) -> None:
    part = probe("RunLog.select", LOG.select, mask, names=("mask",),
                 ok=lambda log: 0 <= len(log) <= len(LOG) and log.max_rcm_deviation() >= 0)  # fmt: skip
    if part is not None:
        probe("RunLog.max_rcm_deviation", part.max_rcm_deviation, ok=finite)
    probe("RunLog", rp.RunLog, **{**LOG_FIELDS, field: value}, names=(field,),
          ok=lambda log: len(log) == len(log.tip) == len(log.step))  # fmt: skip
    path = value if isinstance(value, str) else NPZ if isinstance(value, list) else __file__
    probe("RunLog.load_npz", rp.RunLog.load_npz, path, names=("path",),
          ok=lambda log: len(log) == len(LOG) and np.allclose(log.tip, LOG.tip))  # fmt: skip
