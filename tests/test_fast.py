"""The compiled fast path equals the reference code: kernels, batches, the control loop, errors."""

from __future__ import annotations

from collections.abc import Iterator

import numba  # noqa: F401  (the `fast` extra: without it these tests fail, they do not skip)
import numpy as np
import pytest

from rcmplan import Iramis, IramisParameters
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.records import robot_params
from rcmplan.compiled.runner import FastIramis, fast_check_targets
from rcmplan.control import (
    DlsSolver,
    LoopSettings,
    Phase,
    PinvSolver,
    TipSolver,
)
from rcmplan.control.augmented import augmented_jacobian, extended_task
from rcmplan.control.log import RunLog
from rcmplan.controller import Controller
from rcmplan.exceptions import (
    ConvergenceError,
    SingularPoseError,
    SliderLimitError,
    UnreachableTargetError,
)
from rcmplan.robot import iramis_kernels
from rcmplan.robot.curved_block import BLOCK_ROWS
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import injection, spiral
from rcmplan.sim import KinematicPlant
from rcmplan.sim.mujoco.compiled import exact_plant

from conftest import random_joints
from logcheck import assert_same_log as same_log
from paths import use_path

TOL = 1e-12


@pytest.fixture(autouse=True)
def fast_on() -> Iterator[None]:
    use_path("on")
    yield
    use_path(None)


# Controller dispatches to the compiled loop on the kinematic plant while the mode is "on".
FastController = Controller


def reference_run(ctl: Controller, phases: list[Phase]) -> RunLog:
    use_path("off")
    try:
        return ctl.run(phases)
    finally:
        use_path("on")


def assert_same_log(a: RunLog, b: RunLog) -> None:
    same_log(a, b, TOL)


def test_kernels_equal_reference_over_random_poses(robot: Iramis, rng: np.random.Generator) -> None:
    fast = FastIramis(robot)
    for q in random_joints(rng, 200):
        lam = float(rng.uniform(0.0, 1.0))
        np.testing.assert_allclose(fast.task(q, lam), extended_task(robot, q, lam), atol=TOL)
        for variant in ("exact", "thesis"):
            J = augmented_jacobian(robot, q, lam, variant)
            np.testing.assert_allclose(fast.augmented_jacobian(q, lam, variant), J, atol=TOL)


def test_needle_point_kernel_equals_forward_kinematics(
    robot: Iramis, rng: np.random.Generator
) -> None:
    kernels, P, p = iramis_kernels, robot_params(robot), np.empty(3)
    for q in random_joints(rng, 100):
        kernels.needle_point(P, q, 1.0, p)
        np.testing.assert_allclose(p, robot.forward_kinematics(q)[:3, 3], atol=TOL)


def test_control_step_equals_pinv_solver(robot: Iramis, rng: np.random.Generator) -> None:
    fast, K = FastIramis(robot), rng.uniform(0.2, 1.8, 6)
    for variant in ("exact", "thesis"):
        solver = PinvSolver(K=tuple(K), variant=variant)
        for q in random_joints(rng, 100):
            lam = float(rng.uniform(0.0, 1.0))
            target = extended_task(robot, q + rng.normal(0.0, 1e-3, 6), lam)
            dq, dlam = solver.step(robot, q, lam, target, solver.error(robot, q, lam, target))
            d = fast.step(q, lam, target, K, variant)
            np.testing.assert_allclose(d, [*dq, dlam], atol=TOL)


def test_batch_equals_single_evaluations(robot: Iramis, rng: np.random.Generator) -> None:
    fast = FastIramis(robot)
    Q, lam = random_joints(rng, 50), rng.uniform(0.0, 1.0, 50)
    for variant in ("exact", "thesis"):
        X, J = fast.batch_task_jacobians(Q, lam, variant)
        for i in range(50):
            np.testing.assert_array_equal(X[i], fast.task(Q[i], lam[i]))
            np.testing.assert_array_equal(J[i], fast.augmented_jacobian(Q[i], lam[i], variant))


SOLVERS = [PinvSolver(), PinvSolver(variant="thesis"), DlsSolver()]


@pytest.mark.parametrize("solver", SOLVERS, ids=["pinv", "pinv-thesis", "dls"])
@pytest.mark.parametrize("procedure", [injection, spiral])
def test_compiled_loop_equals_reference_controller(robot: Iramis, procedure, solver) -> None:
    eye = default_eye(robot)
    phases = procedure(robot, eye, default_points(eye))
    ref = reference_run(Controller(KinematicPlant(robot), solver), phases)
    fast = FastController(KinematicPlant(robot), solver).run(phases)
    assert_same_log(ref, fast)


def run_both(robot: Iramis, phases: list[Phase], error: type, **kw: object) -> tuple:
    """Run the reference and the compiled loop, both expected to raise `error`."""
    out = []
    for make in (Controller, FastController):
        ctl = make(KinematicPlant(robot), PinvSolver(), **kw)
        run = ctl.run if make is FastController else lambda p, c=ctl: reference_run(c, p)
        with pytest.raises(error) as info:
            run(phases)
        out.append((info.value, ctl))
    (a, ca), (b, cb) = out
    # Same exception and message; printed error values may differ in the last bits.
    assert type(a) is type(b) and str(a).split("|error|")[0] == str(b).split("|error|")[0]
    if isinstance(a, ConvergenceError):
        np.testing.assert_allclose(a.error, b.error, rtol=0, atol=TOL)
    assert_same_log(a.log, b.log)
    np.testing.assert_allclose(ca.plant.read_actuators(), cb.plant.read_actuators(), atol=TOL)
    assert ca.plant.time == cb.plant.time and abs(ca.lam - cb.lam) <= TOL
    return a, b


def test_iteration_cap_raises_convergence_error_with_partial_log(robot: Iramis) -> None:
    eye = default_eye(robot)
    phases = injection(robot, eye, default_points(eye))
    a, _ = run_both(robot, phases, ConvergenceError, settings=LoopSettings(max_iterations=1))
    assert len(a.log) > 0


def test_singular_pose_raises_singular_pose_error(robot: Iramis) -> None:
    eye = default_eye(robot)
    phases = injection(robot, eye, default_points(eye))
    run_both(robot, phases, SingularPoseError, settings=LoopSettings(singular_threshold=0.9999))


def test_slider_travel_raises_slider_limit_error(robot: Iramis) -> None:
    eye = default_eye(robot)
    approach = injection(robot, eye, default_points(eye))[:1]
    upper = (0.04, 0.04, 0.04, 0.04, 0.002, np.pi)
    narrow = Iramis(IramisParameters(slider_upper=upper))
    a, _ = run_both(narrow, approach, SliderLimitError, free_solver=TipSolver())
    assert a.slider == "L5"


def test_target_screen_raises_like_solve_pose(robot: Iramis) -> None:
    eye = default_eye(robot)
    targets = injection(robot, eye, default_points(eye))[2].plan(robot.home).copy()
    targets[7, 0] += 0.2  # the tip 20 cm further along x: lambda far outside [0, 1]
    with pytest.raises(UnreachableTargetError) as ref:
        Controller(KinematicPlant(robot), PinvSolver()).check_targets(targets)
    with pytest.raises(UnreachableTargetError) as fast:
        fast_check_targets(robot, targets)
    assert str(ref.value) == str(fast.value)


class SteppedPlant(KinematicPlant):
    """The kinematic plant, taken through the per-iteration path used for plants with dynamics."""


@pytest.mark.parametrize("solver", SOLVERS, ids=["pinv", "pinv-thesis", "dls"])
def test_per_iteration_path_equals_reference_controller(robot: Iramis, solver) -> None:
    eye = default_eye(robot)
    phases = injection(robot, eye, default_points(eye))
    ref = reference_run(Controller(KinematicPlant(robot), solver), phases)
    fast = Controller(SteppedPlant(robot), solver).run(phases)
    assert_same_log(ref, fast)


def test_per_iteration_path_stops_like_the_reference(robot: Iramis) -> None:
    eye = default_eye(robot)
    phases = injection(robot, eye, default_points(eye))
    out = []
    for plant, run in ((KinematicPlant(robot), reference_run), (SteppedPlant(robot), None)):
        ctl = Controller(plant, PinvSolver(), settings=LoopSettings(max_iterations=1))
        with pytest.raises(ConvergenceError) as info:
            run(ctl, phases) if run else ctl.run(phases)
        out.append(info.value)
    assert str(out[0]).split("|error|")[0] == str(out[1]).split("|error|")[0]
    assert_same_log(out[0].log, out[1].log)


def test_a_first_run_says_once_that_numba_compiles_and_clears_numbas_cache(tmp_path) -> None:
    """A process that compiles one of rcmplan's kernels prints one line on stderr
    (`_jit.FirstCompile`); the next process loads them from numba's cache and says nothing. A
    small kernel (the task values) stands for any; a whole run would only compile more. A new
    stamp (here another cache folder) first clears rcmplan's kernels from numba's cache
    (NUMBA_CACHE_DIR), so they compile again, and the line says so; but with no stamp to record
    it, clearing would recompile everything on every run: a cache folder rcmplan cannot write
    (here a file) leaves numba's cache as it is, nothing compiles and nothing is said."""
    import json
    import subprocess
    import sys

    code = (
        "from rcmplan import Iramis\n"
        "from rcmplan.compiled.runner import FastIramis\n"
        "robot = Iramis()\n"
        "robot.needle_point(robot.home, 0.5)\n"  # a robot kernel before any compiled module
        "print(FastIramis(robot).task(robot.home, 0.5).tolist())\n"
    )
    robot = Iramis()
    expected = FastIramis(robot).task(robot.home, 0.5)
    # Cache folders of its own: the runs compile afresh and leave the suite's caches alone.
    numba_dir = tmp_path / "numba"
    (tmp_path / "file").write_text("not a folder")
    said, caches = [], []
    for home in ("cache", "cache", "cache2", "file"):
        env = {"XDG_CACHE_HOME": str(tmp_path / home), "NUMBA_CACHE_DIR": str(numba_dir),
               "PATH": "/usr/bin:/bin"}  # fmt: skip
        run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             env=env, check=True)  # fmt: skip
        np.testing.assert_array_equal(json.loads(run.stdout), expected)  # the compiled values
        said.append(run.stderr)
        caches.append({p: p.stat().st_mtime_ns for p in numba_dir.rglob("*.nb[ic]")})
    line = "rcmplan: numba compiles kernels that this kind of run uses for the first time"
    assert [text.count(line) for text in said] == [1, 0, 1, 0]
    assert said[1] == said[3] == ""
    assert caches[0] and caches[1] == caches[0]  # loaded, not compiled again
    assert caches[2].keys() == caches[0].keys()
    assert all(caches[2][p] > caches[0][p] for p in caches[0])  # cleared, compiled again
    assert caches[3] == caches[2]  # nothing cleared, nothing compiled again


def test_kernels_are_cleared_whenever_their_sources_differ_from_the_last_clearing(
    tmp_path, monkeypatch
) -> None:  # type: ignore[no-untyped-def]
    """Sources A, then B, then A again (a downgrade, an edit undone): each change clears the
    kernels numba cached for the other version (a loop cached with B's callees would run them
    on A's arrays), and a process with unchanged sources clears nothing."""
    from numba.core.caching import _CacheLocator

    from rcmplan import _kernel_cache

    source = tmp_path / "src" / "kernels.py"
    source.parent.mkdir()
    monkeypatch.setattr(_kernel_cache, "kernel_sources", lambda: [source])
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba"))
    cached = tmp_path / "numba" / _CacheLocator.get_suitable_cache_subpath(str(source)) / "k.nbi"
    cached.parent.mkdir(parents=True)
    cleared = []
    for version in ("A", "A", "B", "B", "A"):
        source.write_text(f"# version {version}\n")
        cached.write_text(f"compiled by a process that saw {version}")  # what that run compiles
        monkeypatch.setattr(_kernel_cache, "_checked", [False])  # a new process
        _kernel_cache.check_once()
        cleared.append(not cached.exists())
    assert cleared == [True, False, True, False, True]
    assert _kernel_cache.stamp_path().read_text().strip() == _kernel_cache.stamp_key()


def test_the_first_run_stamp_covers_every_file_that_holds_a_kernel() -> None:
    """numba checks a cached kernel against its own file only, so the stamp that clears the
    cache must change with every file holding a kernel (`_kernel_cache.kernel_sources`)."""
    from pathlib import Path

    import rcmplan

    package = Path(rcmplan.__file__).parent
    holding = {p for p in package.rglob("*.py") if "@njit" in p.read_text()}
    from rcmplan._kernel_cache import kernel_sources

    assert holding <= set(kernel_sources())


@pytest.mark.parametrize("code", ["QP", "CURVED_PINV", "CURVED_QP", "PINV", "PINV with qpa"])
def test_the_loop_refuses_a_method_without_the_arrays_it_reads(robot: Iramis, code: str) -> None:
    """The loop picks the QP's and the curved needle's code by their arrays alone (numba prunes
    the other methods' branches): a call naming the method without its arrays is refused, not
    run as another method, and so is a straight needle's method given a curved needle's work
    block or the QP's arrays."""
    from rcmplan.compiled import records

    x0 = extended_task(robot, robot.home, 1.0)
    target = np.r_[x0[:3], 0.0, x0[3:]] if code.startswith("CURVED") else x0
    C = np.empty((BLOCK_ROWS, 7)) if code in ("CURVED_QP", "PINV") else None
    qpa = None
    if code == "PINV with qpa":
        from rcmplan.compiled.qp_params import qp_params
        from rcmplan.control.qp import QpSolver

        qpa = fast_cache.qp_kernels().loop_qp(qp_params(robot, QpSolver(robot)))
    method = getattr(records, code.split()[0])
    args = (robot_params(robot), None, method, np.ones(7), 0.0, np.full(7, 1e-8), 10,
            True, np.array([0.1, 0.0]), qpa, C, target[None, :], 0, 0,
            robot.home_actuators.copy(), np.empty(6), np.array([1.0, 0.0, 1e-3]),
            np.empty((20, 36)), np.empty((20, 2), dtype=np.int64), np.zeros(3, dtype=np.int64),
            np.empty(records.FAIL_WIDTH), exact_plant(),
            fast_cache.algorithm().work_arrays(6))  # fmt: skip
    with pytest.raises(ValueError, match="need qpa, a curved needle's methods C"):
        fast_cache.algorithm().run_targets(*args)


def test_the_loop_refuses_a_call_without_a_robot(robot: Iramis) -> None:
    """Neither iRAM!S's parameters nor an arm's arrays: refused, not run as a loop with no
    iteration (which would end DONE without a step)."""
    from rcmplan.compiled import records

    x0 = extended_task(robot, robot.home, 1.0)
    args = (None, None, records.PINV, np.ones(6), 0.0, np.full(6, 1e-8), 10, True,
            np.array([0.1, 0.0]), None, None, x0[None, :], 0, 0, robot.home_actuators.copy(),
            np.empty(6), np.array([1.0, 0.0, 1e-3]), np.empty((20, 35)),
            np.empty((20, 2), dtype=np.int64), np.zeros(3, dtype=np.int64),
            np.empty(records.FAIL_WIDTH), exact_plant(),
            fast_cache.algorithm().work_arrays(6))  # fmt: skip
    with pytest.raises(ValueError, match="give iRAM!S's P or an arm's arrays"):
        fast_cache.algorithm().run_targets(*args)


def test_the_loop_refuses_scratch_made_for_another_robot(robot: Iramis) -> None:
    """The loop allocates nothing: its scratch comes from the caller (`work_arrays(n)`), and
    scratch for a 7-joint arm given to iRAM!S's six actuators is refused before any record."""
    from rcmplan.compiled import records

    x0 = extended_task(robot, robot.home, 1.0)
    rec = np.full((20, 35), -1.0)
    args = (robot_params(robot), None, records.PINV, np.ones(6), 0.0, np.full(6, 1e-8), 10,
            True, np.array([0.1, 0.0]), None, None, x0[None, :], 0, 0,
            robot.home_actuators.copy(), np.empty(6), np.array([1.0, 0.0, 1e-3]), rec,
            np.empty((20, 2), dtype=np.int64), np.zeros(3, dtype=np.int64),
            np.empty(records.FAIL_WIDTH), exact_plant())  # fmt: skip
    with pytest.raises(ValueError, match=r"work must be work_arrays\(s.shape\[0\]\)"):
        fast_cache.algorithm().run_targets(*args, fast_cache.algorithm().work_arrays(7))
    assert np.all(rec == -1.0)  # nothing written
    status = fast_cache.algorithm().run_targets(*args, fast_cache.algorithm().work_arrays(6))
    assert status == records.DONE


def test_the_compile_line_is_said_once_by_the_command_not_by_its_workers(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """`_jit.FirstCompile` at an rcmplan kernel's compile: the line once in the command's
    process, none in a multiprocessing worker (a sweep's), none for another package's."""
    import multiprocessing
    from types import SimpleNamespace

    from rcmplan._jit import FirstCompile
    from rcmplan.compiled.kernels import task

    def compiled(fn: object) -> SimpleNamespace:
        return SimpleNamespace(data={"dispatcher": SimpleNamespace(py_func=fn)})

    said = []
    for parent in (None, object()):
        monkeypatch.setattr(multiprocessing, "parent_process", lambda p=parent: p)
        listener = FirstCompile()
        listener.on_start(compiled(np.linalg.norm))  # not rcmplan's
        listener.on_start(compiled(task.py_func))
        listener.on_start(compiled(task.py_func))
        said.append(capsys.readouterr().err)
    assert said == [FirstCompile.LINE + "\n", ""]
