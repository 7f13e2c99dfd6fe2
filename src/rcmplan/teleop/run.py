"""Running a session: a replay (recorded or synthetic track) as fast as possible, or live input
paced at wall-clock time.

Both keep their work when they stop early: an rcmplan error (an RCM bound, a failed QP, a
plant limit) ends the session with its status and the partial log; an interrupt
(KeyboardInterrupt, the CLI's SIGTERM) is re-raised with the partial result attached as
`result`, status "interrupted".
"""

from __future__ import annotations

import contextlib
import gc
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rcmplan._signals import raise_interrupt
from rcmplan.control.log import RunLog
from rcmplan.exceptions import RcmplanError
from rcmplan.teleop.live import LiveInput
from rcmplan.teleop.samples import MasterSample, MasterTrack
from rcmplan.teleop.session import Session, TeleopState
from rcmplan.teleop.settings import TeleopSettings
from rcmplan.teleop.trace import Trace
from rcmplan.teleop.violations import count, violation_masks

OnPeriod = Callable[[TeleopState], None]
MAX_LAG_PERIODS = 10  # live: further behind than this, the schedule restarts from now


@dataclass
class TeleopResult:
    """What a session produced.

    Attributes:
        settings: The session's settings.
        log: The run log (one record per period; partial if the session stopped early).
        trace: The pipeline's per-period arrays.
        events: Clutch events (time, kind, tip).
        status: "ok", "limit_violated" (the log breaks a fixture: `violations`),
            "interrupted" or the stopping error's status.
        message: Why the session stopped ("" when it ran to the end).
        wall_time_s: Wall time of the session [s].
        source: The input ("synthetic", a file name, "live").
        intended: The intended master motion (N, 3) per period [m] when the input knows it.
        pacing: Live pacing figures (overruns, restarts), else empty.
        filter_delay_s: The filter's stated lag of the intended motion [s].
        violations: Violating periods per fixture (`teleop.violations`).
        session: The session (its robot, eye, workspace box, pipeline), for measuring.
    """

    settings: TeleopSettings
    log: RunLog
    trace: Trace
    events: list[dict[str, object]]
    status: str
    message: str
    wall_time_s: float
    source: str
    session: Session
    intended: np.ndarray | None = None
    pacing: dict[str, Any] = field(default_factory=dict)
    filter_delay_s: float = 0.0
    error: RcmplanError | None = None
    violations: dict[str, int] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """True when the session ran to its end within every fixture."""
        return self.status == "ok"


def run_replay(
    settings: TeleopSettings, track: MasterTrack, on_period: OnPeriod | None = None
) -> TeleopResult:
    """Run a track's whole duration, one period per dt, as fast as the computer goes; the
    sample of each period is the latest one at or before its time (sample and hold)."""
    n = int(np.floor(track.duration / settings.dt + 1e-9)) + 1
    session = Session(settings)
    player = track.player()
    start = time.perf_counter()

    def loop() -> None:
        for k in range(n):
            state = session.period(player.sample(k * settings.dt))
            if on_period is not None:
                on_period(state)

    return _run(session, loop, start, track.source, _intended(track, settings.dt, n))


def _intended(track: MasterTrack, dt: float, n: int) -> np.ndarray | None:
    if track.intended is None:
        return None
    player = track.player()
    return np.array([track.intended[player.index(k * dt)] for k in range(n)])


def run_live(
    settings: TeleopSettings,
    live_input: LiveInput,
    stop_event: threading.Event,
    on_period: OnPeriod | None = None,
    duration: float | None = None,
) -> TeleopResult:
    """Run at wall-clock pace in the calling thread until `stop_event` is set (or `duration`
    [s] of plant time has passed), one period per dt on `live_input.latest()`, calling
    `on_period(state)` after each period (it must return quickly: it runs in the loop).

    A sample older than `settings.stale_after` counts as released: the needle holds when the
    device stops sending. A period that starts more than MAX_LAG_PERIODS late restarts the
    schedule from now (counted in `pacing["restarts"]`); late periods are counted in
    `pacing["overruns"]`.
    """
    session = Session(settings)
    pacing = {"overruns": 0, "restarts": 0, "periods": 0}
    start = time.perf_counter()

    def loop() -> None:
        with frozen_heap():
            paced()

    def paced() -> None:
        t0, k = time.perf_counter(), 0  # the schedule: period k is due at t0 + k dt
        while not stop_event.is_set():
            if duration is not None and pacing["periods"] * settings.dt > duration + 1e-12:
                break
            now = time.perf_counter()
            deadline = t0 + k * settings.dt
            if now < deadline:
                time.sleep(deadline - now)
            elif now > deadline + settings.dt:
                pacing["overruns"] += 1
                if now > deadline + MAX_LAG_PERIODS * settings.dt:
                    pacing["restarts"] += 1
                    t0, k = now, 0
            sample = _fresh(live_input.latest(), settings.stale_after)
            state = session.period(sample)
            pacing["periods"] += 1
            k += 1
            if on_period is not None:
                on_period(state)

    return _run(session, loop, start, "live", None, pacing)


@contextlib.contextmanager
def frozen_heap() -> Iterator[None]:
    """Run a paced loop with every object that exists now out of the garbage collector's
    reach (`gc.freeze`): a full collection then visits only what the loop allocates, instead
    of the hundreds of thousands of objects numba and the models hold (30-45 ms, which at
    1 kHz is 30-45 missed periods)."""
    gc.collect()
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def _fresh(sample: MasterSample, stale_after: float) -> MasterSample:
    """The sample, released if it is older than stale_after [s] (live input's clock)."""
    if sample.clutch and time.monotonic() - sample.t > stale_after:
        return sample._replace(clutch=False)
    return sample


def _run(
    session: Session, loop: Callable[[], None], start: float, source: str,
    intended: np.ndarray | None, pacing: dict[str, Any] | None = None,
) -> TeleopResult:  # fmt: skip
    status, message, error = "ok", "", None
    try:
        loop()
    except RcmplanError as exc:
        status, error = exc.status, exc
        message = " ".join(f"{type(exc).__name__}: {exc}".split())
    except BaseException as exc:  # an interrupt carries the periods so far, as `result`

        def partial(interrupt: KeyboardInterrupt) -> TeleopResult:
            why = "interrupted by " + getattr(interrupt, "signal_name", "SIGINT")
            return _result(session, start, source, intended, pacing, "interrupted", why)

        raise_interrupt(exc, partial)
    return _result(session, start, source, intended, pacing, status, message, error)


def _result(
    session: Session, start: float, source: str, intended: np.ndarray | None,
    pacing: dict[str, Any] | None, status: str, message: str,
    error: RcmplanError | None = None,
) -> TeleopResult:  # fmt: skip
    log, trace = session.log.finish(), session.trace.finish()
    n = min(len(log), len(trace))
    if len(log) != n:
        log = log.select(np.arange(len(log)) < n)
    if intended is not None:
        intended = intended[:n]
    cfg = session.settings
    masks = violation_masks(log, session.eye, session.box, cfg.fixtures, session.robot, cfg.dt)
    counts = count(masks)
    if status == "ok" and any(counts.values()):
        status = "limit_violated"
        broken = ", ".join(f"{k} in {v} periods" for k, v in counts.items() if v)
        message = f"the session broke its fixtures: {broken}"
    return TeleopResult(
        settings=cfg, log=log, trace=_cut(trace, n), events=session.events(),
        status=status, message=message, wall_time_s=time.perf_counter() - start,
        source=source, intended=intended, pacing=pacing or {},
        filter_delay_s=session.pipeline.filter.delay_s, error=error, violations=counts,
        session=session,
    )  # fmt: skip


def _cut(trace: Trace, n: int) -> Trace:
    """The first n rows of a trace (the log and the trace always end together)."""
    if len(trace) == n:
        return trace
    from dataclasses import fields

    return Trace(**{f.name: getattr(trace, f.name)[:n] for f in fields(trace)})
