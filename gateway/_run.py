"""Running the gateway as a server: bind, announce the address, serve until SIGINT/SIGTERM."""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import os
import socket
import sys
import threading
from collections.abc import AsyncIterator, Iterator

from aiohttp import web

from ..components.core import ComponentHost
from ._app import create_app
from ._config import GatewayConfig
from ._errors import GatewayError
from ._connection import GatewayConnection
from ._ahead import ahead_of_the_routes
from ._fast_answers import FastAnswers
from ._fast_reads import FastReads
from ._fast_sends import FastSends
from ._shutdown import HANDLER_GRACE
from ._routes_admin import ANSWERED_AHEAD
from ._signals import STOP_SIGNALS, signal_name

__all__ = ["serve", "serve_in_thread", "run", "ListenError"]


class ListenError(GatewayError, OSError):
    """The gateway cannot listen on its address (the port is taken, a privileged port, not a local address).

    Attributes:
        host: The address asked for.
        port: The port asked for.
        reason: The system's reason (``address already in use``...).
    """

    def __init__(self, host: str, port: int, cause: OSError) -> None:
        # asyncio's message repeats the address; the bare reason reads better after ours.
        reason = os.strerror(cause.errno) if cause.errno is not None and cause.errno > 0 else (
            cause.strerror or str(cause))
        super().__init__(cause.errno, reason)
        self.host, self.port, self.reason = host, port, reason.lower()

    def __str__(self) -> str:
        return f"cannot listen on {self.host}:{self.port}: {self.reason}"


@contextlib.asynccontextmanager
async def serve(config: GatewayConfig, host: ComponentHost | None = None) -> AsyncIterator[str]:
    """Serve the gateway while the context is open; yield its base URL (with the real port).

    The application is :func:`~._app.create_app`'s, as a test or an embedder builds it.
    Each connection is a :class:`~._connection.GatewayConnection` (aiohttp's own, with
    the gateway's refusals and head timeout), and plain port reads and sends and plain GETs
    of ``/`` and ``/version`` are answered ahead of the routes (:mod:`._ahead`).

    Args:
        config: The gateway configuration (``port=0`` picks a free port).
        host: Serve this component host instead of building one from *config*.
    """
    app = create_app(config, host)
    runner = web.AppRunner(app, handle_signals=False, access_log=None, shutdown_timeout=HANDLER_GRACE)
    await runner.setup()
    listener: asyncio.Server | None = None
    try:
        server = runner.server
        assert server is not None
        server.request_handler = ahead_of_the_routes(FastReads(app), FastSends(app), FastAnswers(app, ANSWERED_AHEAD),
                                                     server.request_handler)
        limits, address, port = config.connections, config.server.host, config.server.port
        try:
            listener = await asyncio.get_running_loop().create_server(
                lambda: GatewayConnection(server, limits, access_log=None), address, port)
        except OSError as exc:
            raise ListenError(address, port, exc) from exc
        bound_host, bound_port = listener.sockets[0].getsockname()[:2]
        shown = f"[{bound_host}]" if ":" in bound_host else bound_host
        yield f"http://{shown}:{bound_port}"
    finally:
        if listener is not None:
            listener.close()
        await runner.cleanup()


@contextlib.contextmanager
def serve_in_thread(config: GatewayConfig, host: ComponentHost | None = None) -> Iterator[str]:
    """Serve the gateway on an event loop of its own thread while the context is open; yield its URL.

    For scripts and notebooks that want a simulated rig next to a blocking client:
    the gateway never competes with the caller's thread, even inside Jupyter,
    whose main thread already runs an event loop.
    """
    started: concurrent.futures.Future[tuple[str, asyncio.Event]] = concurrent.futures.Future()

    async def main() -> None:
        try:
            async with serve(config, host) as url:
                stop = asyncio.Event()
                started.set_result((url, stop))
                await stop.wait()
        except BaseException as exc:
            if not started.done():
                started.set_exception(exc)
            raise

    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_until_complete, args=(main(),), name="aiogenomix-gateway",
                              daemon=True)
    thread.start()
    url, stop = started.result(timeout=60)
    try:
        yield url
    finally:
        loop.call_soon_threadsafe(stop.set)
        thread.join(timeout=60)
        loop.close()


async def _serve_until_signalled(config: GatewayConfig) -> None:
    loop = asyncio.get_running_loop()
    main = asyncio.current_task()
    assert main is not None
    stop = asyncio.Event()
    serving = False

    def on_signal(signum: int) -> None:
        if stop.is_set():
            return  # already stopping, within a bounded time
        stop.set()
        print(f"aiogenomix gateway stopping on {signal_name(signum)}", file=sys.stderr, flush=True)
        if not serving:
            main.cancel()  # still starting: abandon the start (what was loaded is stopped)

    # The loop takes the signals over from the handler that raised StopSignal while importing.
    for signum in STOP_SIGNALS:
        loop.add_signal_handler(signum, on_signal, signum)
    try:
        async with serve(config) as url:
            serving = True
            simulated = config.simulated_parts()
            note = f" (simulated: {'; '.join(simulated)})" if simulated else " (no simulated parts)"
            print(f"aiogenomix gateway listening on {url}{note}", flush=True)
            # What a new user opens next, and where the audio components serve their sockets.
            print(f"  console {url}/console · OpenAPI {url}/openapi.json · "
                  f"dedicated audio sockets on port {config.rig.audio_socket_port} (DedicatedSocket)", flush=True)
            view = config.view
            if view.foxglove_port is not None:
                host = f"[{view.foxglove_host}]" if ":" in view.foxglove_host else view.foxglove_host
                shown_port = view.foxglove_port or "<free port, in the log>"
                token = "/?token=<the token>" if config.access.token else ""
                print(f"  Foxglove view ws://{host}:{shown_port}{token} (in Foxglove or Lichtblick: open a "
                      "connection, Foxglove WebSocket)", flush=True)
            taken = _port_taken(config.server.host, config.rig.audio_socket_port)
            if taken:
                print(f"aiogenomix gateway: warning: the audio socket port {config.rig.audio_socket_port} is taken "
                      f"({taken}): DedicatedSocket will fail until it is free; choose another with "
                      "--audio-socket-port", file=sys.stderr, flush=True)
            await stop.wait()
    except asyncio.CancelledError:
        if not stop.is_set():
            raise
        main.uncancel()


def _port_taken(host: str, port: int) -> str | None:
    """Why *port* cannot be listened on now (None: it can, or 0 picks a free one at each DedicatedSocket).

    The audio components bind it only when a client asks for their socket: a port taken by another program
    would otherwise be found long after start, by whoever asks first.
    """
    if not port:
        return None
    try:
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        with socket.socket(family, socket.SOCK_STREAM) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            probe.bind((host, port))
    except OSError as exc:
        return exc.strerror or str(exc)
    return None


def run(config: GatewayConfig) -> None:
    """Serve until SIGINT or SIGTERM, then stop every component and end every open reply, within 2 s.

    Raises:
        ListenError: The HTTP port cannot be listened on.
    """
    asyncio.run(_serve_until_signalled(config))
