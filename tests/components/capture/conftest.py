"""Fixtures of the capture tests: a host on a sped-up clock with the capture component loaded."""

from __future__ import annotations

from collections.abc import AsyncIterator

import pytest

from aiogenomix.components.capture import Capture
from aiogenomix.components.core import ComponentHost, HostSettings, ScaledClock

#: One second of audio takes 20 ms of real time in these tests.
TIME_SCALE = 50.0


@pytest.fixture
async def host() -> AsyncIterator[ComponentHost]:
    """A host whose dedicated socket takes a free port and whose default device is the simulation."""
    async with ComponentHost(clock=ScaledClock(TIME_SCALE), settings=HostSettings(audio_socket_port=0),
                             factories={"capture": Capture}) as running:
        yield running


@pytest.fixture
async def capture(host: ComponentHost) -> Capture:
    """A loaded capture component."""
    component = await host.load("capture")
    assert isinstance(component, Capture)
    return component
