"""Fixtures of the gateway's tests: a kept-alive raw connection to a gateway serving ``demo``."""

from __future__ import annotations

from collections.abc import AsyncIterator

import pytest

from aiogenomix.components.core import ComponentHost, ScaledClock
from aiogenomix.gateway import GatewayConfig, serve
from tests.gateway._raw_http import Connection


@pytest.fixture
async def connection(gateway_config: GatewayConfig) -> AsyncIterator[Connection]:
    """A raw connection to a gateway (the test module's ``gateway_config``) whose host runs ``demo`` in real time."""
    async with ComponentHost(clock=ScaledClock(1)) as host:
        await host.load("demo")
        async with serve(gateway_config, host=host) as url:
            opened = await Connection.open(url)
            try:
                yield opened
            finally:
                await opened.close()
