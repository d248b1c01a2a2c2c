"""The explorer's local web server: a Bokeh server on 127.0.0.1 over one loaded dataset.

:func:`start_server` binds the port first (a port in use is refused before anything else runs),
then serves the page of :mod:`.page`: one :class:`~.session.ExploreSession` per browser tab, all
sharing the dataset's arrays and its lookup index. Only the loopback interface is bound and only
pages from it may open the websocket; BokehJS is served by the server itself (``/static``), so
the page makes no request that leaves the machine.
"""

from __future__ import annotations

import asyncio
import errno
import logging
import socket
import threading
from dataclasses import dataclass, field
from typing import Any

from .data import ExploreData
from .designs import DesignFinder

__all__ = ["HOST", "PortError", "RunningServer", "check_port", "reserve_port", "start_server"]

logger = logging.getLogger(__name__)

#: The only interface the server listens on.
HOST = "127.0.0.1"


class PortError(OSError):
    """A port the server cannot listen on; the message is one line naming it."""


def check_port(port: int | None) -> None:
    """Refuse a port the server could not listen on, before any work is done.

    Raises
    ------
    PortError
        The port is in use, out of range, or not ours to bind.
    """
    reserve_port(port).close()


def reserve_port(port: int | None) -> socket.socket:
    """A socket bound to ``HOST:port`` (a free port for None or 0).

    Raises
    ------
    PortError
        The port is in use, out of range, or not ours to bind.
    """
    if port is not None and not 0 <= port <= 65535:
        raise PortError(f"port {port}: not a port number (0-65535)")
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        sock.bind((HOST, port or 0))
    except OSError as exc:
        sock.close()
        if exc.errno == errno.EADDRINUSE:
            raise PortError(
                f"port {port}: already in use on {HOST}; choose another or omit --port"
            ) from None
        raise PortError(f"port {port}: cannot listen on {HOST} ({exc.strerror or exc})") from None
    sock.setblocking(False)
    return sock


@dataclass
class RunningServer:
    """A started server.

    Attributes
    ----------
    url : str
        The page's address.
    port : int
    server : bokeh.server.server.Server
    thread : threading.Thread or None
        The thread running its event loop (None when it runs in the caller's).
    pages : list of Page
        The pages opened so far, one per browser tab (:class:`~.page.Page`).
    """

    url: str
    port: int
    server: Any
    thread: threading.Thread | None = None
    pages: list = field(default_factory=list)

    def stop(self) -> None:
        """Stop the server and its event loop (and join its thread)."""
        loop = self.server.io_loop
        done = threading.Event()

        def _stop() -> None:
            self.server.stop()
            loop.stop()
            done.set()

        if self.thread is None:
            _stop()
            return
        loop.add_callback(_stop)
        done.wait(10)
        self.thread.join(10)


def _application(data: ExploreData, finder: DesignFinder, sessions: list):
    from bokeh.application import Application
    from bokeh.application.handlers.function import FunctionHandler

    from .page import build_document
    from .session import ExploreSession

    def make(doc) -> None:
        page = build_document(doc, ExploreSession(data, finder))
        sessions.append(page)

        def forget(context) -> None:  # a closed tab's arrays are not kept
            if page in sessions:
                sessions.remove(page)

        doc.on_session_destroyed(forget)

    return Application(FunctionHandler(make))


def start_server(
    data: ExploreData,
    *,
    port: int | None = None,
    finder: DesignFinder | None = None,
    background: bool = False,
) -> RunningServer:
    """Serve the explorer's page over ``data`` on ``HOST``.

    Parameters
    ----------
    data : ExploreData
    port : int, optional
        Port to listen on (default: a free one).
    finder : DesignFinder, optional
        The lookup (default: opened over ``data``, the index built beside it if missing).
    background : bool
        Run the event loop in a thread (tests, benchmarks); otherwise the caller runs
        ``server.io_loop.start()``.

    Raises
    ------
    PortError
        The port is in use or cannot be bound (before the dataset's index is opened).
    """
    if not port:  # a free port, chosen by the system
        with reserve_port(None) as sock:
            port = sock.getsockname()[1]
    check_port(port)
    finder = finder or DesignFinder(data)
    sessions: list = []
    started = threading.Event()
    box: dict[str, Any] = {}

    def build() -> None:
        from bokeh.server.server import Server
        from tornado.ioloop import IOLoop

        try:
            server = Server(
                {"/": _application(data, finder, sessions)},
                io_loop=IOLoop.current(),
                port=port,
                address=HOST,
                allow_websocket_origin=[f"{HOST}:{port}", f"localhost:{port}"],
            )
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                raise PortError(f"port {port}: already in use on {HOST}") from None
            raise
        server.start()
        box["server"], box["sessions"] = server, sessions

    def run() -> None:
        asyncio.set_event_loop(asyncio.new_event_loop())
        try:
            build()
        except BaseException as exc:
            box["error"] = exc
            started.set()
            return
        started.set()
        box["server"].io_loop.start()

    if not background:
        build()
        thread = None
    else:
        thread = threading.Thread(target=run, name="dpfexplore-explore", daemon=True)
        thread.start()
        started.wait(60)
        if "error" in box:
            raise box["error"]
    server = box["server"]
    url = f"http://{HOST}:{server.port}/"
    return RunningServer(url, server.port, server, thread, sessions)
