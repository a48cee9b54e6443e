"""Running the gateway as a server: bind, announce the address, serve until SIGINT/SIGTERM."""

from __future__ import annotations

import asyncio
import contextlib
import signal
from collections.abc import AsyncIterator

from aiohttp import web

from ..components.core import ComponentHost
from ._app import create_app
from ._config import GatewayConfig

__all__ = ["serve", "run"]


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
