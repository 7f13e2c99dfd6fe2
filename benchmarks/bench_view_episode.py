"""The replay of a subretinal episode with its B-scans (`rcmplan view` on `rcmplan subretinal`'s
folder): what bscans.npz adds to the folder and to writing it, and opening and scrubbing the
replay with and without it.

Run alone: python benchmarks/bench_view_episode.py
One default episode (seed 0, 9 Hz, 5 s hold) is run and written to a temporary folder; the
same folder without bscans.npz is the peer. The machine's load average is printed.
"""

from __future__ import annotations

import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path

from rcmplan.cli.subretinal import write_outputs
from rcmplan.subretinal.episode import run_episode
from rcmplan.subretinal.episode_bscans import episode_bscans
from rcmplan.subretinal.episode_settings import EpisodeSettings
from rcmplan.view.replay import ReplayView
from rcmplan.view.run_folder import load_runs
from rcmplan.view.server import start_server, stop_server

SCRUBS = 50


def open_and_scrub(folder: Path) -> tuple[float, float, float]:
    """Seconds to read the folder and to build the replay on a running server; median show
    time [s] over SCRUBS records spread over the run."""
    start = time.perf_counter()
    runs = load_runs(folder)
    read = time.perf_counter() - start
    server = start_server("127.0.0.1", 0)
    start = time.perf_counter()
    view = ReplayView(server, runs)
    build = time.perf_counter() - start
    shows = []
    n = len(runs[0].log)
    for i in range(0, n, max(n // SCRUBS, 1)):
        view.show(i)
        shows.append(view.show_time_s)
    view.close()
    stop_server(server)
    return read, build, statistics.median(shows)


def main() -> None:
    cfg = EpisodeSettings()
    result = run_episode(cfg)
    start = time.perf_counter()
    frames = episode_bscans(result)
    render = time.perf_counter() - start
    with tempfile.TemporaryDirectory() as tmp:
        folder, bare = Path(tmp) / "episode", Path(tmp) / "bare"
        folder.mkdir()
        write_outputs(cfg, folder, figures=False)
        size = (folder / "bscans.npz").stat().st_size
        others = sum(p.stat().st_size for p in folder.iterdir() if p.name != "bscans.npz")
        shutil.copytree(folder, bare)
        (bare / "bscans.npz").unlink()
        print(f"B-scan frames: {len(frames)}, rendered and segmented in {render:.2f} s "
              f"({1e3 * render / len(frames):.1f} ms each)")  # fmt: skip
        print(f"bscans.npz: {size / 1e6:.2f} MB ({size / len(frames) / 1e3:.1f} kB a frame); "
              f"the folder's other files: {others / 1e6:.2f} MB")  # fmt: skip
        for name, path in (("with B-scans", folder), ("without", bare)):
            read, build, show = open_and_scrub(path)
            print(f"{name}: read {read:.3f} s, build the replay {build:.2f} s, "
                  f"show a record (median of {SCRUBS}) {1e3 * show:.1f} ms")  # fmt: skip
    print(f"load average {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
