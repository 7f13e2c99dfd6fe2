"""The live control in a process of its own, so that the view's drawing (and viser's
messages) never hold the interpreter the 1 kHz loop needs.

The child runs `live_control.pace` on a `LiveLoop` it builds itself (a plant or solver that
cannot be built is reported back before any motion); the input and the latest state cross in
shared memory: the parent pushes positions into a `SharedInput` (the `LiveInput` interface),
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

from rcmplan._validate import scalar, vector
from rcmplan.exceptions import RcmplanError
from rcmplan.view.live_control import LiveLoop, LiveSample, LiveSettings, LiveState, pace

TEXT = 240  # bytes of the status and scheduling texts
START_TIMEOUT_S = 120.0


class SharedInput:
    """`LiveInput` in shared memory: (x, y, z [m], clutch, t [s]) and a push count."""

    def __init__(self, ctx: Any, initial_position: Any) -> None:
        self._values = ctx.Array("d", [*vector("position", initial_position, 3), 0.0, 0.0])
        self._pushes = ctx.Value("q", 0)

    def push(self, position_m: Any, clutch: bool = True, t: float | None = None) -> None:
        """Record the latest position (3,) [m] and clutch (InvalidInputError if not finite)."""
        p = vector("position", position_m, 3)
        stamp = time.monotonic() if t is None else scalar("t", t)
        with self._values.get_lock():
            self._values[:] = [*p, 1.0 if clutch else 0.0, stamp]
            self._pushes.value += 1

    def latest(self) -> LiveSample:
        """The latest sample."""
        with self._values.get_lock():
            v = list(self._values)
        return LiveSample(v[4], np.array(v[:3]), v[3] > 0.5)

    @property
    def pushes(self) -> int:
        """Positions pushed so far."""
        return int(self._pushes.value)


class SharedState:
    """The control's latest `LiveState` in shared memory, for `n` joints."""

    SCALARS = ("period", "slots", "missed", "t_s", "rcm_deviation", "max_rcm_deviation",
               "retina_distance")  # fmt: skip
    VECTORS = ("tip", "base", "setpoint", "goal")

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
            setattr(st, name, int(v[i]) if name in ("period", "slots", "missed") else v[i])
        for name in self.VECTORS:
            setattr(st, name, v[k : k + 3])
            k += 3
        st.q, st.s = v[k : k + self.n], v[k + self.n : k + 2 * self.n]
        return st


def _child(
    settings: LiveSettings, inp: SharedInput, out: SharedState, stop: Any, pipe: Any
) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        loop = LiveLoop(settings)
    except RcmplanError as exc:
        pipe.send(f"{type(exc).__name__}: {exc}")
        return
    pipe.send("")
    pace(loop, inp, stop, out.write)


class LiveProcess:
    """The live control running in a child process.

    Args:
        settings: The session (pickled into the child).

    Raises:
        RcmplanError: The child could not build the plant or solver (its message).
    """

    def __init__(self, settings: LiveSettings) -> None:
        ctx = mp.get_context("forkserver")
        self.input = SharedInput(ctx, settings.start_tip)
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
