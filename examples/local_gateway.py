"""Serve a simulated aiogenomix gateway from a background thread, for examples run without a robot."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

from aiogenomix.gateway import GatewayConfig, serve_in_thread


@contextlib.contextmanager
def local_gateway(time_scale: float = 1.0) -> Iterator[str]:
    """Run a gateway on a free port of 127.0.0.1 while the context is open; yield its URL.

    It runs on a thread of its own, so the blocking client can be used from this
    thread, even inside Jupyter, whose main thread already runs an event loop.

    Args:
        time_scale: Robot seconds per real second (above 1, the robot moves faster).
    """
    with serve_in_thread(GatewayConfig(port=0, time_scale=time_scale, audio_socket_port=0)) as url:
        yield url
