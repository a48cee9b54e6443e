"""Fixtures of the client tests: a real gateway on a free port, on the test's loop or on a thread of its own."""

from __future__ import annotations

from collections.abc import AsyncIterator, Iterator

import pytest
from aiogenomix.gateway import GatewayConfig, serve, serve_in_thread

#: Robot seconds per real second: a 1 m move at 0.1 m/s takes half a second.
TIME_SCALE = 20.0


def config() -> GatewayConfig:
    """A gateway on free ports, with a fast clock."""
    return GatewayConfig.of(port=0, time_scale=TIME_SCALE, audio_socket_port=0)


@pytest.fixture
async def gateway_url() -> AsyncIterator[str]:
    """A gateway served on the test's own event loop (for the async client)."""
    async with serve(config()) as url:
        yield url


@pytest.fixture
def threaded_gateway_url() -> Iterator[str]:
    """A gateway served on a thread of its own (for the sync client)."""
    with serve_in_thread(config()) as url:
        yield url
