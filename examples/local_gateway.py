"""Serve a simulated aiogenomix gateway from a background thread, for examples run without a robot."""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import threading
from collections.abc import Iterator, Sequence

from aiogenomix.components.core import ComponentHost, VirtualClock
from aiogenomix.gateway import GatewayConfig, serve


@contextlib.contextmanager
def local_gateway(time_scale: float = 1.0, audio_files: Sequence[str] = ()) -> Iterator[str]:
    """Run a gateway on a free port of 127.0.0.1 while the context is open; yield its URL.

    It runs on a thread of its own, so the blocking client can be used from this
    thread, even inside Jupyter, whose main thread already runs an event loop.
    The simulated rig runs on simulated time (:class:`VirtualClock`): robots stop where
    their controllers tell them whatever the machine's load, which slows the simulation
    down rather than making it late.

    Args:
        time_scale: At most this many robot seconds per real second (above 1, the robot moves faster).
        audio_files: Directories from which clients may name scene and WAV files (``--audio-files``).
    """
    config = GatewayConfig.of(port=0, time_scale=time_scale, audio_socket_port=0, audio_files=list(audio_files))
    started: concurrent.futures.Future[tuple[str, asyncio.Event]] = concurrent.futures.Future()

    async def main() -> None:
        try:
            async with ComponentHost(clock=VirtualClock(time_scale), settings=config.host_settings()) as host, \
                    serve(config, host) as url:
                stop = asyncio.Event()
                started.set_result((url, stop))
                await stop.wait()
        except BaseException as exc:
            if not started.done():
                started.set_exception(exc)
            raise

    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_until_complete, args=(main(),), name="local gateway", daemon=True)
    thread.start()
    url, stop = started.result(timeout=60)
    try:
        yield url
    finally:
        loop.call_soon_threadsafe(stop.set)
        thread.join(timeout=60)
        loop.close()
