"""Shared fixtures: the default robot, a seeded random generator, and every figure any test
draws checked as it is saved (`figcheck`: no legend over an axes, no bound over the data).

RCMPLAN_REQUIRE_BROWSER (set by scripts/check.sh when a Chromium is there, or by hand) makes a
missing Chromium or playwright fail the browser tests instead of skipping them; "0" or unset
does not.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from rcmplan import Iramis

if os.environ.get("RCMPLAN_REQUIRE_BROWSER") == "0":
    del os.environ["RCMPLAN_REQUIRE_BROWSER"]  # the browser tests read any other value as set


# The order the files run in. First the one whose tests fork this process and so need it to run
# no other thread (`analysis.parallel.can_fork`): a Dask client leaves its IO loop's and
# offload's threads behind for the life of the process, so these run before any test that
# starts one (each pytest-xdist worker takes the next file in this order). Then the files that
# take longest, longest first (pytest --durations=0, summed per file, in one run with two
# workers), so that with `--dist loadfile` (scripts/check.sh) the files left for the end are
# short and the workers finish at about the same time. A file not named here runs after these,
# as collected.
RUN_FIRST = (
    "test_parallel.py",
    "test_interrupts.py", "test_view_browser.py", "test_subretinal_episodes.py",
    "test_qp_compiled.py", "test_api_properties.py", "test_interrupts_writes.py",
    "test_sweep_executors.py", "test_subretinal_trace.py", "test_api_properties_control.py",
    "test_view_live.py", "test_view.py", "test_mujoco_methods.py",
)  # fmt: skip


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Run the files in `RUN_FIRST`'s order; deselect the tests marked `heavy` unless
    RCMPLAN_HEAVY_TESTS=1 (tests/heavy.py)."""
    from heavy import HEAVY

    rank = {name: k for k, name in enumerate(RUN_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: else as collected
    if HEAVY:
        return
    keep = [item for item in items if item.get_closest_marker("heavy") is None]
    dropped = [item for item in items if item.get_closest_marker("heavy") is not None]
    if dropped:
        config.hook.pytest_deselected(items=dropped)
        items[:] = keep
        config.stash[HEAVY_DROPPED] = len(dropped)


HEAVY_DROPPED = pytest.StashKey[int]()


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    """Say how many heavy tests were left out, and how to run them."""
    n = terminalreporter.config.stash.get(HEAVY_DROPPED, 0)
    if n:
        terminalreporter.write_line(
            f"{n} heavy tests deselected; RCMPLAN_HEAVY_TESTS=1 (bash scripts/check.sh --heavy) "
            "runs them, and the generated-input suites in full"
        )


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


@pytest.fixture(autouse=True, scope="session")
def _stale_kernels_already_cleared(tmp_path_factory: pytest.TempPathFactory) -> None:
    """Commands run as after their first run: the stamp that says numba's cache was cleared of
    stale kernels (`rcmplan._kernel_cache`) is written in a cache folder of this session, so no
    process of the suite clears the kernels the warm-ups compiled (tests/test_fast.py checks
    the clearing with folders of its own)."""
    import os

    from rcmplan import _kernel_cache

    os.environ["XDG_CACHE_HOME"] = str(tmp_path_factory.mktemp("xdg-cache"))
    stamp = _kernel_cache.stamp_path()
    stamp.parent.mkdir(parents=True, exist_ok=True)
    stamp.write_text(_kernel_cache.stamp_key() + "\n")


@pytest.fixture(autouse=True)
def figures_with_legends_clear(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every figure rcmplan saves in a test (`analysis.style.save`, which every figure goes
    through; a forked drawing child inherits it) fails the save if a legend lies over an axes
    or past the figure's edge, or a bound line over the data (`figcheck`)."""
    from figcheck import bounds_over_data, legend_clashes
    from rcmplan.analysis import style

    save = style.save

    def checked(fig, path):  # type: ignore[no-untyped-def]
        clashes = legend_clashes(fig) + bounds_over_data(fig)
        if clashes:
            style.plt().close(fig)
            raise AssertionError(f"{path}: {'; '.join(clashes)}")
        return save(fig, path)

    monkeypatch.setattr(style, "save", checked)
