"""The KEMAR head through the gateway and the generated client: moves, faults, other sessions unharmed."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from typing import Any

import aiohttp
import pytest

from aiogenomix.clients import Interrupted, RemoteError, aconnect
from aiogenomix.components.core import ComponentHost, HostSettings, VirtualClock
from aiogenomix.components.kemar import MotorFault, simulated_rig
from aiogenomix.gateway import GatewayConfig, serve


@pytest.fixture
async def rig() -> AsyncIterator[tuple[ComponentHost, str]]:
    """A gateway whose host we can reach (to inject drive faults).

    Its simulated time runs at most 50× real time, and only when the rig has nothing else to do;
    the drive has a real-time bound for its replies that holds on a busy machine.
    """
    settings = HostSettings(can="virtual", can_timeout=10.0, audio_socket_port=0)
    async with ComponentHost(clock=VirtualClock(50), settings=settings) as host:
        async with serve(GatewayConfig.of(port=0), host=host) as url:
            yield host, url


async def homed_head_moves_and_reports_its_state(kemar: Any) -> None:
    """Home a loaded ``kemar`` (generated client), then move it and check what it reports."""
    await kemar.Homing()
    await kemar.MoveAbsolutePosition(30)
    state = await kemar.currentState()
    assert state.position == pytest.approx(30, abs=0.1)
    assert state.maxLeft == pytest.approx(90, abs=0.5) and state.maxRight == pytest.approx(-90, abs=0.5)
    await kemar.MoveRelativePosition(-50)
    assert (await kemar.currentState()).position == pytest.approx(-20, abs=0.1)

    # Slow enough (100 degrees at 1 degree/s: 2 s of real time at 50x) for the next request to arrive
    # during it, however busy the machine.
    first = await kemar.MoveAbsolutePosition(80, 1, ack=True)
    await kemar.MoveAbsolutePosition(-10)
    with pytest.raises(Interrupted) as interrupted:
        await first.result()
    assert interrupted.value.by == "MoveAbsolutePosition"
    assert (await kemar.currentState()).position == pytest.approx(-10, abs=0.1)


async def test_head_moves_and_reports_its_state(rig: tuple[ComponentHost, str]) -> None:
    _, url = rig
    async with aconnect(url, timeout=30) as client:
        await homed_head_moves_and_reports_its_state(await client.load("kemar"))


async def test_faults_end_requests_clearly_and_nothing_else_is_disturbed(rig: tuple[ComponentHost, str]) -> None:
    host, url = rig
    async with aconnect(url, timeout=30) as head_session, aconnect(url, timeout=30) as demo_session:
        kemar = await head_session.load("kemar")
        demo = await demo_session.load("demo")
        with pytest.raises(kemar.NOT_HOMED):
            await kemar.MoveAbsolutePosition(10)
        robot = await demo.GotoPosition(0.8, ack=True)  # another session's activity, running meanwhile

        await kemar.Homing()
        drive = simulated_rig(host)
        assert drive is not None
        drive.inject_fault(MotorFault.POSITION_TRACKING, 0x8611)
        with pytest.raises(RemoteError) as fault:
            await kemar.MoveAbsolutePosition(40)
        assert fault.value.ex == "::kemar::DRIVE_FAULT"
        assert "tracking" in str(fault.value).lower()

        host.get("kemar").head().driver.timeout = 0.2  # type: ignore[attr-defined]  # no need to wait 10 s
        drive.set_silent(True)
        with pytest.raises(RemoteError) as silent:
            await asyncio.wait_for(kemar.GetPosition(), 30)  # an error, never a hang
        assert silent.value.ex == "::kemar::BUS_TIMEOUT"
        drive.set_silent(False)

        await kemar.Homing()  # recovers
        await kemar.MoveAbsolutePosition(15)
        assert (await kemar.currentState()).position == pytest.approx(15, abs=0.1)

        await robot.result()
        assert (await demo.Mobile()).position == pytest.approx(0.8)


@pytest.mark.parametrize("query, ex", [
    ('{"target":null}', "::kemar::INVALID_TARGET"),       # genom's JSON null is a NaN double
    ('{"target":NaN}', "::kemar::INVALID_TARGET"),
    ('{"target":Infinity}', "::kemar::INVALID_TARGET"),
    ('{"target":10,"velocity":-5}', "::kemar::INVALID_VELOCITY"),
    ('{"target":10,"velocity":null}', "::kemar::INVALID_VELOCITY"),
])
async def test_targets_that_are_not_numbers_are_refused(rig: tuple[ComponentHost, str], query: str, ex: str) -> None:
    host, url = rig
    async with aconnect(url, timeout=30) as client:
        kemar = await client.load("kemar")
        await kemar.Homing()
        await kemar.MoveAbsolutePosition(12)
        async with aiohttp.ClientSession() as http:
            async with http.get(f"{url}/module/kemar/send/MoveAbsolutePosition", params={"input": query}) as reply:
                body = await reply.json()
                assert (reply.status, body["status"], body["exception"]["ex"]) == (200, "error", ex)
        # Refused before anything moved: the head is where it was.
        assert (await kemar.GetPosition()) == pytest.approx(12, abs=0.1)
