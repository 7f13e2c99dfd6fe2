"""Many subretinal episodes: the draws, their checks, a run's summary against its per-episode
log, resuming, a failed run's partial summary, and Dask against local processes."""

from __future__ import annotations

import argparse
import csv
import json
import socket
from pathlib import Path

import pytest

from rcmplan.cli import interrupts
from rcmplan.cli import subretinal as subretinal_cli
from rcmplan.exceptions import InvalidInputError
from rcmplan.subretinal import episode_batch
from rcmplan.subretinal.episode_batch import BatchSettings, EpisodeRecord, run_batch
from rcmplan.subretinal.episode_draws import CONDITIONS, DrawRanges, draw_episodes
from rcmplan.subretinal.episode_settings import EpisodeSettings
from rcmplan.sweep.errors import SchedulerError
from rcmplan.sweep.executors import DaskExecutor, LocalExecutor

# Short episodes: 0.2 mm approach, 0.1 s hover, 0.2 s hold, advance and retract at 0.5 mm/s.
SHORT = EpisodeSettings(hold_s=0.2, hover_s=0.1, start_height_m=200e-6,
                        advance_speed_m_s=0.5e-3, settle_s=0.05)  # fmt: skip


def test_draws_lie_in_their_ranges_and_repeat_with_the_seed() -> None:
    ranges = DrawRanges(eye_drift_m=(0.0, 300e-6))  # every condition drawn (by default not)
    draws = draw_episodes(ranges, seed=7, n=200)
    for name in CONDITIONS:
        lo, hi = getattr(ranges, name)
        values = [getattr(d, name) for d in draws]
        assert all(lo <= v <= hi for v in values), name
        assert max(values) - min(values) > 0.5 * (hi - lo), name  # spread over the range
    assert draw_episodes(ranges, seed=7, n=200) == draws
    assert draw_episodes(ranges, seed=8, n=200) != draws
    assert draw_episodes(ranges, seed=7, n=5) == draws[:5]  # episode k whatever the count
    assert len({d.seed for d in draws}) == len(draws)


def test_a_target_fraction_given_on_the_command_line_is_fixed_not_drawn() -> None:
    from rcmplan.cli import build_parser
    from rcmplan.cli.subretinal_episodes import batch_of

    args = build_parser().parse_args(["subretinal", "--episodes", "3", "--target-fraction", "0.35"])
    batch = batch_of(args)
    assert batch.ranges.target_fraction == (0.35, 0.35)
    assert batch_of(build_parser().parse_args(["subretinal", "--episodes", "3"])).ranges == (
        DrawRanges()
    )


def test_a_range_of_one_value_fixes_the_condition() -> None:
    ranges = DrawRanges(ioct_rate_hz=(9.0, 9.0), latency_s=(0.15, 0.15))
    draws = draw_episodes(ranges, seed=0, n=10)
    assert {d.ioct_rate_hz for d in draws} == {9.0} and {d.latency_s for d in draws} == {0.15}
    settings = draws[0].settings(SHORT, "fft")
    assert (settings.compensation, settings.ioct_rate_hz, settings.seed) == (
        "fft",
        9.0,
        draws[0].seed,
    )
    assert settings.hold_s == SHORT.hold_s


@pytest.mark.parametrize(
    ("changes", "name", "value", "valid"),
    [
        ({"latency_s": (0.3, 0.1)}, "latency_s[1]", 0.1, "[0.3, 1]"),
        ({"ioct_rate_hz": (0.1, 9.0)}, "ioct_rate_hz[0]", 0.1, "[0.5, 200]"),
        ({"breathing_rate_hz": (0.1, 0.3)}, "breathing_rate_hz[0]", 0.1, "[0.2, 0.33]"),
        ({"cardiac_rate_hz": (1.0, 2.5)}, "cardiac_rate_hz[1]", 2.5, "[1, 2]"),
        ({"noise_std_m": (-1e-6, 1e-6)}, "noise_std_m[0]", -1e-6, "[0, 5e-05]"),
        ({"target_fraction": (0.0, 0.5)}, "target_fraction[0]", 0.0, "(0, 1)"),
        ({"latency_s": 0.1}, "latency_s", 0.1, "a pair (low, high)"),
        ({"latency_s": (0.1, float("nan"))}, "latency_s[1]", "nan", "finite"),
    ],
)
def test_bad_ranges_are_refused_naming_the_value_and_the_range(
    changes: dict, name: str, value: object, valid: str
) -> None:
    with pytest.raises(InvalidInputError) as info:
        DrawRanges(**changes)
    assert info.value.name == name and valid in info.value.valid
    assert str(value) in str(info.value)


def test_ranges_the_episodes_cannot_take_are_refused_before_any_motion() -> None:
    with pytest.raises(InvalidInputError, match=r"target_fraction\[1\] = 0\.95.*\[0\.1, 0\.9\]"):
        BatchSettings(episodes=2, ranges=DrawRanges(target_fraction=(0.5, 0.95)))
    # a target shallower than the ILM's tent is taken (reached by puncturing deeper)
    BatchSettings(episodes=2, ranges=DrawRanges(target_fraction=(0.3, 0.7)))
    reach = DrawRanges(breathing_amplitude_m=(20e-6, 90e-6), cardiac_amplitude_m=(2e-6, 15e-6))
    with pytest.raises(InvalidInputError, match="stand-off, 100 um") as info:
        BatchSettings(episodes=2, ranges=reach)
    assert info.value.name == "breathing_amplitude_m[1] + cardiac_amplitude_m[1]"
    for bad in ({"episodes": 0}, {"episodes": 2, "methods": ("kalman", "kalman")},
                {"episodes": 2, "methods": ("lstm",)}, {"episodes": 2, "seed": -1}):  # fmt: skip
        with pytest.raises(InvalidInputError):
            BatchSettings(**bad)


def test_a_record_is_written_flat_in_its_columns_and_reads_back_equal() -> None:
    draw = draw_episodes(DrawRanges(), seed=5, n=3)[2]
    figures = dict.fromkeys(episode_batch.FIGURES, 1e-6) | {
        "rpe_breach": False,
        "acquisitions_dropped": 0,
    }
    record = EpisodeRecord(id=9, draw=draw, compensation="kalman", ioct_estimates="noise",
                           status="ok", success=True, **figures, wall_time_s=0.5)  # fmt: skip
    row = record.as_dict()
    assert list(row) == [
        "id", "episode", "compensation", "ioct_estimates", "status", "success", "seed",
        "breathing_amplitude_m", "cardiac_amplitude_m", "breathing_rate_hz", "cardiac_rate_hz",
        "ioct_rate_hz", "latency_s", "noise_std_m", "target_fraction", "eye_drift_m",
        "tracking_rms_m", "depth_error_m", "depth_rms_error_m", "in_band_fraction", "rpe_breach",
        "max_depth_past_rpe_m", "max_rcm_deviation_m", "prediction_rms_m",
        "max_trocar_displacement_m", "segmentation_rms_m", "acquisitions_dropped", "wall_time_s",
        "message",
    ]  # fmt: skip
    assert (row["episode"], row["seed"], row["latency_s"]) == (2, draw.seed, draw.latency_s)
    assert EpisodeRecord.from_dict(json.loads(json.dumps(row))) == record
    with pytest.raises(KeyError):
        EpisodeRecord.from_dict({k: v for k, v in row.items() if k != "seed"})


def test_image_estimates_record_no_noise_and_run_with_the_bases() -> None:
    batch = BatchSettings(episodes=1, methods=("none",), base=SHORT)
    record = episode_batch.run_job(batch, 0)
    assert batch.base.ioct_estimates == "image" and record.as_dict()["noise_std_m"] is None
    assert EpisodeRecord.from_dict(json.loads(json.dumps(record.as_dict()))) == record
    assert record.draw.settings(SHORT, "none").noise_std_m == SHORT.noise_std_m


def run_cli(argv: list[str]) -> int:
    parser = argparse.ArgumentParser()
    subretinal_cli.register(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["subretinal", *argv])
    return int(args.run(args))


CLI = ["--episodes", "2", "--hold-s", "0.2", "--hover-s", "0.1", "--workers", "1", "--json"]


def read_log(out: Path) -> list[dict[str, str]]:
    with open(out / "episodes.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def test_an_interrupted_run_resumes_and_its_summary_matches_its_log(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    real, ran = episode_batch.run_jobs, []

    def cut_after_three(batch, items):
        if len(ran) == 3:
            raise interrupts.Interrupted
        ran.extend(items)
        return real(batch, items)

    monkeypatch.setattr(episode_batch, "run_jobs", cut_after_three)
    with pytest.raises(KeyboardInterrupt):
        run_cli([*CLI, "--out", str(tmp_path)])
    cut = json.loads((tmp_path / "summary.json").read_text())
    assert cut["status"] == "interrupted" and "--resume" in cut["message"]
    assert list(cut)[:3] == ["command", "status", "message"]  # as every command's summary
    assert cut["jobs_run"] == 3 and len(read_log(tmp_path)) == 3

    resumed: list[int] = []
    monkeypatch.setattr(episode_batch, "run_jobs",
                        lambda batch, items: (resumed.extend(items), real(batch, items))[1])  # fmt: skip
    capsys.readouterr()
    assert run_cli([*CLI, "--out", str(tmp_path), "--resume"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert sorted(resumed) == [3, 4, 5, 6, 7]
    assert doc["resumed"] == {"requested": True, "resumed_from_checkpoint": 3,
                              "started_afresh": False, "message": ""}  # fmt: skip
    assert doc["status"] == "ok" and doc["episodes_planned"] == 2 and doc["jobs_run"] == 8
    assert list(doc)[:3] == ["command", "status", "message"]
    rows = read_log(tmp_path)
    assert sorted(int(r["id"]) for r in rows) == list(range(8))
    for method, m in doc["methods"].items():
        mine = [r for r in rows if r["compensation"] == method]
        successes = sum(r["success"] == "True" for r in mine)
        breaches = sum(r["rpe_breach"] == "True" for r in mine)
        assert (m["episodes"], m["successes"], m["rpe_breaches"]) == (
            len(mine),
            successes,
            breaches,
        )
        assert m["success_rate"] == successes / len(mine)
        ok_in_band = [r["status"] == "ok" and float(r["in_band_fraction"]) == 1.0 for r in mine]
        assert [r["success"] == "True" for r in mine] == ok_in_band
    best = doc["methods"][doc["method"]]
    for key in ("episodes", "success_rate", "rpe_breaches", "tracking_rms_m_median"):
        assert doc[key] == best[key]
    assert doc["method_choice"] and set(doc["methods"]) == {"none", "hold", "fft", "kalman"}
    assert set(doc["curves"]) == {"ioct_rate_hz", "latency_s"}
    for curve in doc["curves"].values():
        assert sum(curve["methods"]["kalman"]["episodes"]) == 2


def unused_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_a_failed_run_writes_its_partial_summary_and_says_why(tmp_path: Path) -> None:
    address = f"tcp://127.0.0.1:{unused_port()}"
    with pytest.raises(SchedulerError):
        run_cli([*CLI, "--scheduler", address, "--timeout", "1", "--out", str(tmp_path)])
    doc = json.loads((tmp_path / "summary.json").read_text())
    assert doc["status"] == "scheduler_error" and "SchedulerError" in doc["message"]
    assert list(doc)[:3] == ["command", "status", "message"]
    assert doc["jobs_run"] == 0 and doc["episodes_planned"] == 2
    assert "success_rate" in doc["methods"]["kalman"]


def test_one_episode_refuses_all_methods(tmp_path: Path) -> None:
    with pytest.raises(InvalidInputError, match="--episodes"):
        run_cli(["--compensation", "all", "--out", str(tmp_path)])


def test_a_dask_cluster_gives_the_records_of_local_processes() -> None:
    import distributed  # the `dist` extra; a missing package must fail, not skip

    batch = BatchSettings(episodes=2, seed=3, base=SHORT)
    with LocalExecutor(1) as ex:
        local = run_batch(batch, ex)
    with (
        distributed.LocalCluster(
            n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None
        ) as cluster,
        DaskExecutor(cluster.scheduler_address, timeout_s=30) as ex,
    ):
        remote = run_batch(batch, ex)
    assert sorted(local.records) == sorted(remote.records) == list(range(8))
    assert {i: r.identity() for i, r in remote.records.items()} == {
        i: r.identity() for i, r in local.records.items()
    }
    drawn = {tuple(getattr(r.draw, c) for c in CONDITIONS) for r in local.records.values()}
    assert len(drawn) == 2  # two drawn episodes, each run by every method
