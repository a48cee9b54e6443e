"""Running the gateway as a server: bind, announce the address, serve until SIGINT/SIGTERM."""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import signal
import threading
from collections.abc import AsyncIterator, Iterator

from aiohttp import web

from ..components.core import ComponentHost
from ._app import create_app
from ._config import GatewayConfig

__all__ = ["serve", "serve_in_thread", "run"]


@contextlib.asynccontextmanager
async def serve(config: GatewayConfig, host: ComponentHost | None = None) -> AsyncIterator[str]:
    """Serve the gateway while the context is open; yield its base URL (with the real port).

    Args:
        config: The gateway configuration (``port=0`` picks a free port).
        host: Serve this component host instead of building one from *config*.
    """
    runner = web.AppRunner(create_app(config, host), handle_signals=False, access_log=None)
    await runner.setup()
    try:
        site = web.TCPSite(runner, config.host, config.port)
        await site.start()
        bound_host, bound_port = runner.addresses[0][:2]
        shown = f"[{bound_host}]" if ":" in bound_host else bound_host
        yield f"http://{shown}:{bound_port}"
    finally:
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
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for signum in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(signum, stop.set)
    async with serve(config) as url:
        simulated = config.simulated_parts()
        note = f" (simulated: {'; '.join(simulated)})" if simulated else " (no simulated parts)"
        print(f"aiogenomix gateway listening on {url}{note}", flush=True)
        await stop.wait()


def run(config: GatewayConfig) -> None:
    """Serve until SIGINT or SIGTERM, then stop every component cleanly."""
    asyncio.run(_serve_until_signalled(config))
