"""Checkpoints: results written as they arrive, resumed without rework, corruption detected."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from rcmplan.sweep.checkpoint import Checkpoint
from rcmplan.sweep.errors import CheckpointError
from rcmplan.sweep.executors import LocalExecutor
from rcmplan.sweep.runner import run_sweep, run_targets
from rcmplan.sweep.sampling import sample_region
from rcmplan.sweep.settings import MotionSettings, Region, SweepSettings

SETTINGS = SweepSettings(
    Region(max_angle=math.radians(15), n_targets=10),
    MotionSettings(step_position=1e-3, step_angle=1e-2),
)


class InterruptError(Exception):
    pass


@pytest.fixture(scope="module")
def fresh():
    with LocalExecutor(1) as ex:
        return run_sweep(SETTINGS, ex)


def interrupted_checkpoint(path: Path, after_chunks: int) -> Checkpoint:
    """Run a sweep that is interrupted after some chunks; return the checkpoint."""
    cp = Checkpoint.open(path, SETTINGS, resume=False)
    seen = []

    def stop(results) -> None:
        seen.append(results)
        if len(seen) == after_chunks:
            raise InterruptError

    with LocalExecutor(1) as ex, pytest.raises(InterruptError):
        run_sweep(SETTINGS, ex, cp, on_chunk=stop, chunk_size=2)
    return cp


def test_an_interrupted_sweep_keeps_every_finished_chunk(tmp_path: Path, fresh) -> None:
    cp = interrupted_checkpoint(tmp_path / "cp", after_chunks=2)
    done = Checkpoint.open(tmp_path / "cp", SETTINGS, resume=True).load()
    assert len(cp.chunk_files()) == 2 and len(done) == 4
    assert {i: r.identity() for i, r in done.items()} == {
        i: fresh.results[i].identity() for i in done
    }


def test_a_resumed_sweep_skips_done_targets_and_matches_a_fresh_run(tmp_path: Path, fresh) -> None:
    interrupted_checkpoint(tmp_path / "cp", after_chunks=2)
    ran = []
    cp = Checkpoint.open(tmp_path / "cp", SETTINGS, resume=True)
    with LocalExecutor(1) as ex:
        resumed = run_sweep(SETTINGS, ex, cp, on_chunk=lambda rs: ran.extend(r.id for r in rs))
    assert resumed.resumed == 4
    assert len(ran) == len(fresh.results) - 4 and not set(ran) & set(cp.load()) - set(ran)
    assert {i: r.identity() for i, r in resumed.results.items()} == {
        i: r.identity() for i, r in fresh.results.items()
    }


def test_a_complete_checkpoint_runs_nothing_again(tmp_path: Path) -> None:
    sample = sample_region(SETTINGS.region, SETTINGS.motion)
    ids = sample.reachable_ids.tolist()
    with LocalExecutor(1) as ex:
        cp = Checkpoint.open(tmp_path / "cp", SETTINGS, resume=False)
        run_targets(SETTINGS.motion, sample, ids, ex, cp)
        calls = []
        _, resumed = run_targets(SETTINGS.motion, sample, ids, ex, cp, on_chunk=calls.append)
    assert resumed == len(ids) and calls == []


def test_an_existing_checkpoint_is_not_reused_without_resume(tmp_path: Path) -> None:
    interrupted_checkpoint(tmp_path / "cp", after_chunks=1)
    with pytest.raises(CheckpointError, match="--resume"):
        Checkpoint.open(tmp_path / "cp", SETTINGS, resume=False)


def test_a_checkpoint_for_other_settings_is_refused(tmp_path: Path) -> None:
    interrupted_checkpoint(tmp_path / "cp", after_chunks=1)
    other = SweepSettings(Region(max_angle=math.radians(15), n_targets=11), SETTINGS.motion)
    with pytest.raises(CheckpointError, match=r"header\.json.*other sweep settings"):
        Checkpoint.open(tmp_path / "cp", other, resume=True)


def test_a_checkpoint_of_the_hyphenated_statuses_is_refused_naming_its_header(
    tmp_path: Path,
) -> None:
    # As an older rcmplan wrote it: format version 1, statuses spelled "no-convergence".
    cp = interrupted_checkpoint(tmp_path / "cp", after_chunks=1)
    header = tmp_path / "cp" / "header.json"
    header.write_text(json.dumps({**json.loads(header.read_text()), "version": 1}))
    chunk = cp.chunk_files()[0]
    data = json.loads(chunk.read_text())
    data["results"][0]["status"] = "no-convergence"
    chunk.write_text(json.dumps(data))
    with pytest.raises(CheckpointError, match="format version 1, expected 2") as info:
        Checkpoint.open(tmp_path / "cp", SETTINGS, resume=True)
    assert info.value.path == header and "no-convergence" in info.value.problem
    assert "no_convergence" in info.value.problem


def test_a_truncated_chunk_is_named_as_corrupt(tmp_path: Path) -> None:
    cp = interrupted_checkpoint(tmp_path / "cp", after_chunks=2)
    bad = cp.chunk_files()[1]
    bad.write_text(bad.read_text()[:40])
    reopened = Checkpoint.open(tmp_path / "cp", SETTINGS, resume=True)
    with pytest.raises(CheckpointError, match="corrupt") as info:
        reopened.load()
    assert info.value.path == bad and bad.name in str(info.value)


def test_an_edited_result_fails_the_checksum(tmp_path: Path) -> None:
    cp = interrupted_checkpoint(tmp_path / "cp", after_chunks=1)
    path = cp.chunk_files()[0]
    data = json.loads(path.read_text())
    data["results"][0]["iterations"] += 1
    path.write_text(json.dumps(data))
    with pytest.raises(CheckpointError, match="checksum") as info:
        Checkpoint.open(tmp_path / "cp", SETTINGS, resume=True).load()
    assert path.name in str(info.value)


def test_a_corrupt_header_is_named(tmp_path: Path) -> None:
    interrupted_checkpoint(tmp_path / "cp", after_chunks=1)
    (tmp_path / "cp" / "header.json").write_text("{not json")
    with pytest.raises(CheckpointError, match=r"header\.json.*corrupt"):
        Checkpoint.open(tmp_path / "cp", SETTINGS, resume=True)


def test_a_stray_temporary_file_is_removed_and_never_read(tmp_path: Path) -> None:
    cp = interrupted_checkpoint(tmp_path / "cp", after_chunks=1)
    stray = tmp_path / "cp" / "chunk-0000099.json.123.tmp"
    stray.write_text("{half a chunk")
    reopened = Checkpoint.open(tmp_path / "cp", SETTINGS, resume=True)
    assert not stray.exists() and len(reopened.load()) == len(cp.load())


def test_a_chunk_write_interrupted_mid_file_leaves_no_temporary_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from rcmplan.sweep import checkpoint as module

    def interrupted(fd: int) -> None:
        raise KeyboardInterrupt  # SIGINT (or the CLI's SIGTERM) between write and rename

    monkeypatch.setattr(module.os, "fsync", interrupted)
    with pytest.raises(KeyboardInterrupt):
        module.write_atomic(tmp_path / "chunk-0000000.json", "{}")
    assert list(tmp_path.iterdir()) == []
