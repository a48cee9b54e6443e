"""The gateway tells its rig's clock at ``/``: the time its ports' data are stamped with, and how fast it runs."""

from __future__ import annotations

import math

import pytest
from aiogenomix.clients import aconnect, connect
from aiogenomix.components.core import ComponentHost, HostSettings, ManualClock
from aiogenomix.gateway import GatewayConfig, serve

TIME_SCALE = 20.0  # as tests/clients/conftest.py serves its gateways


async def test_a_simulated_clock_is_told_as_it_stands() -> None:
    clock = ManualClock(start=100.0)
    async with ComponentHost(clock=clock, settings=HostSettings(audio_socket_port=0)) as host, \
            serve(GatewayConfig.of(port=0), host) as url, aconnect(url) as client:
        told = await client.clock()
        await clock.advance(2.5)
        later = await client.clock()
    assert told is not None and later is not None
    assert (told.kind, told.scale, told.wall) == ("ManualClock", math.inf, clock.wall() - 2.5)
    assert later.wall - told.wall == pytest.approx(2.5)  # it moves with the simulation, not with real time


def test_a_scaled_clock_says_its_rate(threaded_gateway_url: str) -> None:
    with connect(threaded_gateway_url) as client:
        told = client.clock()
    assert told is not None and (told.kind, told.scale) == ("ScaledClock", TIME_SCALE)
