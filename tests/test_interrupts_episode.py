"""A real `rcmplan subretinal` process (one episode) signalled while its episode runs: it keeps
the periods recorded so far (summary.json "interrupted" with the signal, the phase reached and
the periods, log.npz and episode.npz holding as many), exits 130 / 143, and prints no
traceback (docs/report.md, "A run stopped early")."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from rcmplan.cli import interrupts
from rcmplan.control.log import RunLog
from rcmplan.subretinal.episode import Episode
from rcmplan.subretinal.episode_settings import EpisodeSettings
from test_interrupts import SRC, check_left, our_tracebacks

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="needs POSIX signals")

RUNNING = "rcmplan subretinal: running the episode"  # its stderr line as the periods begin
# Past the warm-up's iOCT volumes (about 0.2 s) into the periods, well short of the end of a
# 30 s hold's 34,350 periods (about 1.2 s on the compiled block path).
INTO_THE_RUN_S = 0.5


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_an_episode_signalled_while_it_runs_keeps_its_records(sig: int, tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "bscans.npz").write_bytes(b"an earlier run's B-scans")
    proc = subprocess.Popen(
        [sys.executable, "-m", "rcmplan", "subretinal", "--no-plots", "--hold-s", "30",
         "--out", str(out)],
        env={**os.environ, "PYTHONPATH": SRC}, stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert proc.stderr is not None
    seen = []
    for line in proc.stderr:
        seen.append(line)
        if line.startswith(RUNNING):
            break
    time.sleep(INTO_THE_RUN_S)
    proc.send_signal(sig)
    _, rest = proc.communicate(timeout=120)
    err = "".join(seen) + rest
    assert any(line.startswith(RUNNING) for line in seen), err[-2000:]
    assert proc.returncode == 128 + sig and not our_tracebacks(err), err[-2000:]

    doc = json.loads((out / "summary.json").read_text())
    name = signal.Signals(sig).name
    assert doc["status"] == "interrupted"
    assert doc["message"].startswith(f"interrupted by {name} during the run, "), err[-2000:]
    log = RunLog.load_npz(out / "log.npz")
    assert doc["periods"] == len(log)
    with np.load(out / "episode.npz") as episode:
        assert episode["t_s"].size == len(log)
    if len(log):
        phase = log.phase_names[int(log.phase[-1])]
        assert f"in the {phase} phase after {len(log)} of 34350 periods" in doc["message"]
    else:  # the signal came during the warm-up's iOCT volumes
        assert "before the first of 34350 periods" in doc["message"]
    assert not (out / "bscans.npz").exists()  # not rendered on an interrupt; the old one gone
    check_left(out, "subretinal", proc.returncode, sig, err)


def test_an_interrupt_numba_wraps_still_carries_the_periods_recorded(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # SIGTERM landing in numba's dispatcher (a cached kernel's first call) comes out as a
    # SystemError whose cause is the interrupt: the episode raises the interrupt itself.
    episode = Episode(EpisodeSettings(hold_s=1.0, hover_s=0.5))
    plan, calls = Episode.plan, []

    def plan_then_stop(self: Episode, k: int) -> None:
        calls.append(k)
        if len(calls) == 40:
            try:
                raise interrupts.Terminated()
            except interrupts.Terminated as cause:
                raise SystemError("a dispatcher returned a result with an exception set") from cause
        plan(self, k)

    monkeypatch.setattr(Episode, "plan", plan_then_stop)
    with pytest.raises(interrupts.Terminated) as info:
        episode.run()
    result = info.value.result  # type: ignore[attr-defined]
    n = len(result.log)
    assert n == result.series["t_s"].size == calls[-1] > 0
    phase = result.log.phase_names[int(result.log.phase[-1])]
    assert list(result.phase_starts_s)[-1] == phase  # no phase it did not reach
    assert result.status == "interrupted"
    assert result.message == (f"interrupted by SIGTERM during the run, in the {phase} phase "
                              f"after {n} of {episode.n_periods} periods")  # fmt: skip
    assert isinstance(info.value.__cause__, SystemError)
