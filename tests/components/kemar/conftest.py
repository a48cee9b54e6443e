"""Fixtures of the KEMAR tests: a simulated drive on a unique virtual bus, a driver, the head, a host."""

from __future__ import annotations

from collections.abc import AsyncIterator

import pytest

from aiogenomix.components.core import ComponentHost, HostSettings, VirtualClock
from aiogenomix.components.kemar import HarmonicaDriver, Kemar, KemarHead, SimulatedHarmonica

#: Real seconds the simulated drive has to answer a request.  The CAN reply timeout is real time by
#: design (decision 8), and a drive served by a thread of this process answers late when both cores
#: are busy: a bound that holds there (a real bus gets the host's 0.5 s).  The tests of time-outs
#: set their own, short ones, and wait for a silent drive.
CAN_TIMEOUT = 10.0


@pytest.fixture
def clock() -> VirtualClock:
    """The rig's clock: simulated time that moves when the rig has nothing else to do.

    Homing (about 9 s of rig time) takes a fraction of a second, and where the head
    stops does not depend on how busy the machine is.
    """
    return VirtualClock()


@pytest.fixture
async def sim(clock: VirtualClock) -> AsyncIterator[SimulatedHarmonica]:
    """A simulated drive, head at azimuth 0, on its own virtual channel."""
    async with SimulatedHarmonica(clock=clock) as drive:
        yield drive


@pytest.fixture
async def driver(sim: SimulatedHarmonica) -> AsyncIterator[HarmonicaDriver]:
    """A started driver on the simulated drive's bus."""
    async with HarmonicaDriver.open("virtual", sim.channel, timeout=CAN_TIMEOUT, clock=sim.clock) as drive:
        yield drive


@pytest.fixture
def head(driver: HarmonicaDriver, clock: VirtualClock) -> KemarHead:
    """The head logic, not homed yet."""
    return KemarHead(driver, clock)


@pytest.fixture
async def homed_head(head: KemarHead) -> KemarHead:
    """The head after a successful homing."""
    await head.home()
    return head


@pytest.fixture
async def host(clock: VirtualClock) -> AsyncIterator[ComponentHost]:
    """A host with the kemar component loadable, on the virtual bus (simulated drive)."""
    async with ComponentHost(clock=clock, settings=HostSettings(can="virtual", can_timeout=CAN_TIMEOUT),
                             factories={"kemar": Kemar}) as running:
        yield running


@pytest.fixture
async def kemar(host: ComponentHost) -> Kemar:
    """A loaded kemar component."""
    component = await host.load("kemar")
    assert isinstance(component, Kemar)
    return component
