"""The view's web server: viser's, started on a checked port, its address printed.

viser moves on to the next free port when the one asked for is taken; the view instead
refuses a busy port with PortInUseError, so a second viewer never lands silently on another
address. viser's own start and stop banners are kept off the terminal: the command prints one
line with the address.
"""

from __future__ import annotations

import contextlib
import errno
import io
import socket
import threading
import webbrowser
from collections.abc import Iterator
from typing import Any

from rcmplan.exceptions import InvalidInputError, PortInUseError, require_extra

DEFAULT_PORT = 8080
DEFAULT_HOST = "127.0.0.1"


# viser (1.1) wakes its sender by setting an asyncio.Event from the calling thread as well as
# from its loop; from another thread (the live view's redraw, the replay's playback) that can
# race the loop's own use of the event, and the call raises "deque mutated during iteration"
# after its message is queued. Seen once in a test run: the live view's redraw thread ended and
# the view froze. A thread that updates the scene counts such a call and goes on.
VISER_RACE = "mutated during iteration"


def viser_race(exc: BaseException) -> bool:
    """True if exc is viser's thread race (VISER_RACE): the update is queued, the next one
    goes on."""
    return isinstance(exc, RuntimeError) and VISER_RACE in str(exc)


def viser_module() -> Any:
    """The `viser` module, or MissingExtraError naming the `view` extra."""
    return require_extra("viser", "view")


def check_port(host: str, port: int) -> None:
    """Raise PortInUseError if (host, port) cannot be bound because it is taken, and
    InvalidInputError for a host or port that cannot be bound at all."""
    if not 0 <= port <= 65535:
        raise InvalidInputError("--port", port, "0 (any free port) or 1..65535")
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except socket.gaierror as exc:
        raise InvalidInputError("--host", host, f"an address of this machine ({exc})") from exc
    family, kind, proto, _, address = infos[0]
    with socket.socket(family, kind, proto) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as asyncio's server does
        try:
            probe.bind(address)
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                raise PortInUseError(host, port) from exc
            why = f"an address and port this user may bind ({exc})"
            raise InvalidInputError("--host/--port", f"{host}:{port}", why) from exc


@contextlib.contextmanager
def quiet() -> Iterator[None]:
    """viser's banners (printed with rich to stdout) kept off the terminal."""
    with contextlib.redirect_stdout(io.StringIO()):
        yield


def start_server(host: str = DEFAULT_HOST, port: int = DEFAULT_PORT, label: str = "rcmplan") -> Any:
    """A running viser server on exactly (host, port); PortInUseError if the port is taken."""
    viser = viser_module()
    check_port(host, port)
    with quiet():
        server = viser.ViserServer(host=host, port=port, label=label, verbose=False)
    if port and server.get_port() != port:  # taken between the check and viser's bind
        stop_server(server)
        raise PortInUseError(host, port)
    # Plain lights, no shadows and no environment map: the scene is simple shapes, and a
    # browser without a GPU (software WebGL) then draws its first frame in seconds, not tens.
    server.scene.configure_environment_map(None)
    server.scene.configure_default_lights(enabled=True, cast_shadow=False)
    server.scene.add_light_ambient("/lights/ambient", intensity=0.8)
    return server


def stop_server(server: Any) -> None:
    """Stop a server quietly."""
    with quiet():
        server.stop()


def address(server: Any, host: str) -> str:
    """The page's URL."""
    shown = f"[{host}]" if ":" in host else host
    return f"http://{shown}:{server.get_port()}/"


def open_browser(url: str) -> None:
    """Open the page in the user's browser, without waiting for it."""
    threading.Thread(target=webbrowser.open, args=(url,), daemon=True).start()


def serve(stop: threading.Event, poll_s: float = 0.2) -> None:
    """Block until `stop` is set (or Ctrl-C raises in the main thread)."""
    while not stop.wait(poll_s):
        pass
