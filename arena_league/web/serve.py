"""Running the web service: uvicorn on one application (:func:`serve`, ``arena-league serve``)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

__all__ = ["serve"]


def serve(*, host: str = "127.0.0.1", port: int = 8000, home: str | Path | None = None, url: str | None = None,
          workers: int = 1, on_listening: Callable[[], None] | None = None) -> None:
    """Serve the league at ``home`` / ``url`` on ``host:port`` until interrupted, with ``workers``
    job workers beside it (0: jobs wait for ``arena-league worker`` processes started elsewhere).
    ``on_listening`` is called once the port is held, before the league is opened.
    One log line per request goes to stderr (the application's own, which names who asked; uvicorn's
    access log is off)."""
    import logging
    import os
    import socket
    import sys

    import uvicorn

    from arena_league.web.app import create_app

    # listen before anything starts, so that a port in use is one line and no worker is left behind
    try:
        listening = socket.create_server((host, port), family=socket.AF_INET6 if ":" in host else socket.AF_INET)
        # asyncio sets TCP_NODELAY only on the connections of sockets it made itself; the accepted
        # ones inherit it from here (else a play page's second frame waits ~40 ms on a delayed ACK)
        listening.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    except OSError as error:
        why = os.strerror(error.errno) if error.errno else str(error)
        raise ValueError(f"cannot listen on {host}:{port} ({why}); check --host, or choose "
                         "another --port (or stop what holds this one)") from None
    if on_listening is not None:
        on_listening()
    logging.basicConfig(level=logging.INFO, stream=sys.stderr, format="%(asctime)s %(name)s %(message)s")
    app = create_app(home, url, workers=workers)
    # a play page's messages are a few bytes: a WebSocket message over 64 KiB closes its connection
    config = uvicorn.Config(app, access_log=False, log_level="info", ws_max_size=1 << 16)
    with listening:
        uvicorn.Server(config).run(sockets=[listening])
