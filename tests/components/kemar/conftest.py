"""Fixtures of the KEMAR tests: a simulated drive on a unique virtual bus, a driver, the head, a host."""

from __future__ import annotations

from collections.abc import AsyncIterator

import pytest

from aiogenomix.components.core import ComponentHost, HostSettings, ScaledClock
from aiogenomix.components.kemar import HarmonicaDriver, Kemar, KemarHead, SimulatedHarmonica

#: Default speed-up of the simulated rig: homing (about 9 s of rig time) takes about 0.1 s.
TIME_SCALE = 100.0


@pytest.fixture
def clock() -> ScaledClock:
    """The rig's clock (override ``time_scale`` in a module to change the speed-up)."""
    return ScaledClock(TIME_SCALE)


@pytest.fixture
async def sim(clock: ScaledClock) -> AsyncIterator[SimulatedHarmonica]:
    """A simulated drive, head at azimuth 0, on its own virtual channel."""
    async with SimulatedHarmonica(clock=clock) as drive:
        yield drive


@pytest.fixture
async def driver(sim: SimulatedHarmonica) -> AsyncIterator[HarmonicaDriver]:
    """A started driver on the simulated drive's bus."""
    async with HarmonicaDriver.open("virtual", sim.channel, timeout=0.5) as drive:
        yield drive


@pytest.fixture
def head(driver: HarmonicaDriver, clock: ScaledClock) -> KemarHead:
    """The head logic, not homed yet."""
    return KemarHead(driver, clock)


@pytest.fixture
async def homed_head(head: KemarHead) -> KemarHead:
    """The head after a successful homing."""
    await head.home()
    return head


@pytest.fixture
async def host(clock: ScaledClock) -> AsyncIterator[ComponentHost]:
    """A host with the kemar component loadable, on the virtual bus (simulated drive)."""
    async with ComponentHost(clock=clock, settings=HostSettings(can="virtual", can_timeout=0.3),
                             factories={"kemar": Kemar}) as running:
        yield running


@pytest.fixture
async def kemar(host: ComponentHost) -> Kemar:
    """A loaded kemar component."""
    component = await host.load("kemar")
    assert isinstance(component, Kemar)
    return component
