"""The live control in a process of its own, so that the view's drawing (and viser's
messages) never hold the interpreter the 1 kHz loop needs.

The child runs `live_control.run_live` (the teleoperation session; a session that cannot be
built is reported back before any motion); the input and the latest state cross in shared
memory: the parent pushes master positions into a `SharedInput` (the `LiveInput` interface),
the child writes each period's state into a `SharedState` the view reads when it redraws.
The child ignores SIGINT (Ctrl-C reaches the whole process group; the parent stops the child)
and is a daemon: it cannot outlive the view.
"""

from __future__ import annotations

import multiprocessing as mp
import signal
import time
from typing import Any

import numpy as np

from rcmplan._validate import scalar
from rcmplan.exceptions import RcmplanError
from rcmplan.teleop.samples import MasterSample, check_position
from rcmplan.view.live_control import LiveSettings, LiveState, run_live

TEXT = 240  # bytes of the status and scheduling texts
START_TIMEOUT_S = 120.0


class SharedInput:
    """`rcmplan.teleop.LiveInput` in shared memory: (x, y, z [m], clutch, t [s]) of the latest
    master sample and a push count. It starts engaged at `initial_position` (the gizmo's
    starting point), stamped now."""

    def __init__(self, ctx: Any, initial_position: Any) -> None:
        p = check_position("live input", initial_position)
        self._values = ctx.Array("d", [*p, 1.0, time.monotonic()])
        self._pushes = ctx.Value("q", 0)

    def push(self, position_m: Any, clutch: bool = True, t: float | None = None) -> None:
        """Record the latest master position (3,) [m] and clutch (InputStreamError if not 3
        finite numbers within 1 m, as `LiveInput.push`)."""
        p = check_position("live input", position_m)
        stamp = time.monotonic() if t is None else scalar("t", t)
        with self._values.get_lock():
            self._values[:] = [*p, 1.0 if clutch else 0.0, stamp]
            self._pushes.value += 1

    def latest(self) -> MasterSample:
        """The latest sample."""
        with self._values.get_lock():
            v = list(self._values)
        return MasterSample(v[4], np.array(v[:3]), v[3] > 0.5)

    @property
    def pushes(self) -> int:
        """Positions pushed so far."""
        return int(self._pushes.value)


class SharedState:
    """The control's latest `LiveState` in shared memory, for `n` joints."""

    SCALARS = ("period", "slots", "missed", "t_s", "rcm_deviation", "max_rcm_deviation",
               "retina_distance", "engaged")  # fmt: skip
    INTEGERS = ("period", "slots", "missed")
    VECTORS = ("tip", "goal")

    def __init__(self, ctx: Any, n: int) -> None:
        self.n = n
        self._values = ctx.Array("d", len(self.SCALARS) + 3 * len(self.VECTORS) + 2 * n)
        self._status = ctx.Array("c", TEXT)
        self._scheduling = ctx.Array("c", TEXT)
        self.written = ctx.Value("q", 0)

    def write(self, st: LiveState) -> None:
        """Store a state (called by the control after every period)."""
        row = [float(getattr(st, k)) for k in self.SCALARS]
        for k in self.VECTORS:
            row += list(getattr(st, k))
        row += [*st.q, *st.s]
        with self._values.get_lock():
            self._values[:] = row
            self._status.value = st.status.encode()[: TEXT - 1]
            self._scheduling.value = st.scheduling.encode()[: TEXT - 1]
            self.written.value += 1

    def read(self) -> LiveState | None:
        """The latest state, or None before the first period."""
        with self._values.get_lock():
            if self.written.value == 0:
                return None
            v = np.array(self._values[:])
            status = self._status.value.decode(errors="replace")
            scheduling = self._scheduling.value.decode(errors="replace")
        k = len(self.SCALARS)
        st = LiveState(status=status, scheduling=scheduling)
        for i, name in enumerate(self.SCALARS):
            value = v[i] > 0.5 if name == "engaged" else float(v[i])
            setattr(st, name, int(v[i]) if name in self.INTEGERS else value)
        for name in self.VECTORS:
            setattr(st, name, v[k : k + 3])
            k += 3
        st.q, st.s = v[k : k + self.n], v[k + self.n : k + 2 * self.n]
        return st


def _child(
    settings: LiveSettings, inp: SharedInput, out: SharedState, stop: Any, pipe: Any
) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    started = False

    def on_period(st: LiveState) -> None:
        nonlocal started
        if not started:  # the session was built: the parent may go on
            pipe.send("")
            started = True
        out.write(st)

    try:
        final = run_live(settings, inp, stop, on_period)
    except RcmplanError as exc:  # the session could not be built: before any motion
        pipe.send(f"{type(exc).__name__}: {exc}")
        return
    if not started:  # stopped before its first period: say why, if it was an error
        pipe.send(final.status if final.status.startswith("stopped") else "")
    out.write(final)


class LiveProcess:
    """The live control running in a child process.

    Args:
        settings: The session (pickled into the child).

    Raises:
        RcmplanError: The child could not build the session (its message).
    """

    def __init__(self, settings: LiveSettings) -> None:
        ctx = mp.get_context("forkserver")
        self.input = SharedInput(ctx, settings.to_master(settings.start_tip))
        self.shared = SharedState(ctx, len(settings.robot.joint_names))
        self.stop_event = ctx.Event()
        parent, child = ctx.Pipe(duplex=False)
        self.process = ctx.Process(
            target=_child, args=(settings, self.input, self.shared, self.stop_event, child),
            name="rcmplan-live-control", daemon=True,
        )  # fmt: skip
        self.process.start()
        child.close()
        if not parent.poll(START_TIMEOUT_S):
            self.close()
            raise RcmplanError(f"the live control did not start within {START_TIMEOUT_S:g} s")
        try:
            error = parent.recv()
        except EOFError:  # the child ended before it could say (see `multiprocessing`'s
            self.close()  # main-module rule: a script must start the view under __main__)
            error = f"its process ended first (exit code {self.process.exitcode})"
        if error:
            self.close()
            raise RcmplanError(f"the live control cannot start: {error}")

    def latest(self) -> LiveState | None:
        """The control's latest state."""
        return self.shared.read()

    def close(self) -> None:
        """Stop the control and wait for its process."""
        self.stop_event.set()
        self.process.join(timeout=5.0)
        if self.process.is_alive():
            self.process.terminate()
            self.process.join(timeout=5.0)
