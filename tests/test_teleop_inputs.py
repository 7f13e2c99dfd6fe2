"""Teleoperation inputs: replay files checked row by row before motion, the seeded synthetic
surgeon, sample-and-hold playback, and the live input shared between threads."""

from __future__ import annotations

import math
import threading

import numpy as np
import pytest
from scipy import signal

from rcmplan.exceptions import InputStreamError, InvalidInputError
from rcmplan.teleop import LiveInput, MasterTrack, SyntheticSurgeon, read_track, write_track
from rcmplan.teleop.motion_plan import MotionPlan, Move
from rcmplan.teleop.samples import MIN_RATE_HZ, check_track

SHORT = MotionPlan(1.0, (Move(0.2, 0.6, (5e-3, 0.0, 0.0)),), released=((0.0, 0.1),))


def csv_text(rows: list[str], header: str = "time_s,x_m,y_m,z_m,clutch") -> str:
    return "\n".join([header, *rows]) + "\n"


def good_rows(n: int = 50, dt: float = 0.002) -> list[str]:
    return [f"{k * dt!r},{1e-4 * k!r},0.0,0.0,1" for k in range(n)]


def write(tmp_path, rows: list[str], **kw) -> str:
    path = tmp_path / "in.csv"
    path.write_text(csv_text(rows, **kw))
    return str(path)


def test_a_csv_file_reads_back_as_its_columns(tmp_path) -> None:
    track = read_track(write(tmp_path, ["# a comment", *good_rows()]))
    assert len(track) == 50
    assert track.time[1] == 0.002
    assert track.position[3] == pytest.approx([3e-4, 0.0, 0.0])
    assert track.clutch.all()
    assert track.intended is None


def test_csv_columns_may_come_in_any_order_with_extra_columns(tmp_path) -> None:
    rows = [f"{c},7,{t!r},{x!r},0,0" for t, x, c in ((0.0, 0.0, 1), (0.005, 1e-4, 0))]
    track = read_track(write(tmp_path, rows, header="clutch,note,time_s,x_m,y_m,z_m"))
    assert track.clutch.tolist() == [True, False]
    assert track.position[1, 0] == 1e-4


def test_a_file_without_a_column_names_the_missing_column(tmp_path) -> None:
    path = write(tmp_path, ["0,0,0,0"], header="time_s,x_m,y_m,z_m")
    with pytest.raises(InputStreamError, match="missing: clutch") as info:
        read_track(path)
    assert info.value.row is None


@pytest.mark.parametrize(
    ("row", "column", "text"),
    [
        ("0.01,0.0,nan,0.0,1", "position", "finite"),
        ("0.01,0.0,abc,0.0,1", "y_m", "abc"),
        ("0.01,0.0,0.0,0.0,2", "clutch", "0 \\(released\\) or 1"),
        ("0.004,0.0,0.0,0.0,1", "time_s", "increase strictly"),
        ("0.05,0.0,0.0,0.0,1", "time_s", f"{MIN_RATE_HZ:g} Hz"),
        ("0.01,0.05,0.0,0.0,1", "position_m", "at most 2 m/s"),
    ],
)  # fmt: skip
def test_a_bad_row_is_named_with_its_value_before_any_motion(tmp_path, row, column, text) -> None:
    rows = [*good_rows(3, 0.004)[:2], row, "0.012,0.0,0.0,0.0,1"]
    with pytest.raises(InputStreamError, match=text) as info:
        read_track(write(tmp_path, rows))
    assert info.value.row == 2
    assert info.value.column == column
    assert "row 2" in str(info.value)


def test_npz_files_read_with_the_same_checks(tmp_path) -> None:
    track = SyntheticSurgeon(plan=SHORT).track()
    path = write_track(track, tmp_path / "t.npz")
    back = read_track(path)
    assert back.position == pytest.approx(track.position, abs=0.0)
    assert back.intended == pytest.approx(track.intended, abs=0.0)
    assert back.clutch.tolist() == track.clutch.tolist()
    bad = dict(np.load(path))
    bad["time_s"] = bad["time_s"].copy()
    bad["time_s"][7] = bad["time_s"][6]
    np.savez(tmp_path / "bad.npz", **bad)
    with pytest.raises(InputStreamError, match="row 7 time_s"):
        read_track(tmp_path / "bad.npz")
    del bad["clutch"]
    np.savez(tmp_path / "missing.npz", **bad)
    with pytest.raises(InputStreamError, match="missing: clutch"):
        read_track(tmp_path / "missing.npz")


def test_a_csv_written_by_write_track_reads_back_exactly(tmp_path) -> None:
    track = SyntheticSurgeon(plan=SHORT, seed=3).track()
    back = read_track(write_track(track, tmp_path / "t.csv"))
    assert back.position == pytest.approx(track.position, abs=0.0)
    assert back.time == pytest.approx(track.time, abs=0.0)


def test_a_missing_file_is_refused() -> None:
    with pytest.raises(InputStreamError, match="existing CSV or NPZ"):
        read_track("/nonexistent/input.csv")


def test_the_synthetic_surgeon_is_seeded() -> None:
    a = SyntheticSurgeon(plan=SHORT, seed=1).track()
    b = SyntheticSurgeon(plan=SHORT, seed=1).track()
    c = SyntheticSurgeon(plan=SHORT, seed=2).track()
    assert np.array_equal(a.position, b.position)
    assert not np.array_equal(a.position, c.position)


def test_synthetic_tremor_has_its_stated_rms_in_the_tremor_band() -> None:
    surgeon = SyntheticSurgeon(noise_rms=0.0, tremor_rms=80e-6)
    track = surgeon.track()
    tremor = track.position - track.intended
    assert math.sqrt(np.mean(np.sum(tremor**2, axis=1))) == pytest.approx(80e-6, rel=1e-9)
    f, p = signal.welch(tremor, fs=surgeon.rate_hz, nperseg=4096, axis=0)
    in_band = p[(f >= 6.0) & (f <= 16.0)].sum() / p.sum()
    assert in_band > 0.99


def test_the_intended_motion_keeps_its_power_below_2_hz() -> None:
    track = SyntheticSurgeon().track()
    f, p = signal.welch(track.intended - track.intended[0], fs=1000.0, nperseg=8192, axis=0)
    assert p[f <= 2.0].sum() / p.sum() > 0.989  # Riviere et al. 1997: 98.9 % below 2 Hz


def test_the_synthetic_plan_releases_the_clutch_as_scheduled() -> None:
    track = SyntheticSurgeon(plan=SHORT).track()
    assert not track.clutch[track.time < 0.1].any()
    assert track.clutch[track.time >= 0.1].all()


def test_playback_holds_the_latest_sample_at_or_before_each_time() -> None:
    t = np.array([0.0, 0.004, 0.008])
    track = check_track(MasterTrack(t, np.arange(9.0).reshape(3, 3) * 1e-4, np.ones(3, bool)))
    player = track.player()
    assert [player.index(x) for x in (0.0, 0.003, 0.004, 0.0079, 0.1)] == [0, 0, 1, 1, 2]


def test_the_live_input_starts_released_and_keeps_the_latest_push() -> None:
    live = LiveInput(initial_position=[0.01, 0.0, 0.0])
    first = live.latest()
    assert not first.clutch
    assert first.position == pytest.approx([0.01, 0.0, 0.0])
    live.push([0.0, 0.02, 0.0], clutch=True, t=5.0)
    last = live.latest()
    assert (last.t, last.clutch) == (5.0, True)
    assert last.position == pytest.approx([0.0, 0.02, 0.0])


def test_the_live_input_refuses_bad_positions() -> None:
    live = LiveInput()
    for bad in ([0.0, np.nan, 0.0], [0.0, 0.0], [5.0, 0.0, 0.0], "abc"):
        with pytest.raises(InputStreamError):
            live.push(bad)
    with pytest.raises(InvalidInputError):
        live.push([0.0, 0.0, 0.0], t=float("inf"))
    assert live.pushes == 0


def test_pushes_from_many_threads_leave_one_whole_sample() -> None:
    live = LiveInput()

    def pusher(k: int) -> None:
        for i in range(500):
            v = 1e-4 * (k * 1000 + i)
            live.push([v, v, v], clutch=bool(i % 2), t=float(i))

    threads = [threading.Thread(target=pusher, args=(k,)) for k in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    last = live.latest()
    assert live.pushes == 2000
    assert last.position[0] == last.position[1] == last.position[2]
    assert last.clutch == bool(int(last.t) % 2)
