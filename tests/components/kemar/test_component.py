"""The kemar component through the runtime: the acceptance list of issue 4 on the simulated drive."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest

from aiogenomix.components.audio import HeadAzimuth
from aiogenomix.components.core import ComponentHost, HostSettings, VirtualClock
from aiogenomix.components.core.runtime import Request
from aiogenomix.components.kemar import (
    NOT_HOMED, BusError, Kemar, KemarState, MotorFault, SimulatedHarmonica, parse_bus, simulated_rig,
)


async def finish(request: Request) -> Request:
    """Wait for a request to end, within a real-time bound that holds on a busy machine."""
    await asyncio.wait_for(request.ended.wait(), 60)
    return request


async def call(kemar: Kemar, service: str, inputs: Any = None) -> Request:
    return await finish(await kemar.send(service, inputs))


def rig(host: ComponentHost) -> SimulatedHarmonica:
    drive = simulated_rig(host)
    assert drive is not None
    return drive


async def wait_azimuth(host: ComponentHost, clock: VirtualClock, beyond: float) -> None:
    """Wait until the simulated head has turned past *beyond* degrees (either sign)."""
    drive = rig(host)
    while abs(drive.head_azimuth) < abs(beyond):
        await clock.sleep(0.02)


@pytest.fixture
async def homed(kemar: Kemar) -> Kemar:
    assert (await call(kemar, "Homing")).status == "done"
    return kemar


async def test_homing_finds_the_limits_and_publishes_the_state(kemar: Kemar, host: ComponentHost) -> None:
    request = await call(kemar, "Homing")
    assert request.status == "done", request.exception
    state = kemar.currentState.read()
    assert isinstance(state, KemarState)
    assert (state.maxLeft, state.maxRight) == (90.0, -90.0)
    assert abs(state.position) <= 4 / 204.8
    assert state.timestamp.tv_sec > 0
    assert abs(rig(host).head_azimuth) <= 4 / 204.8
    assert kemar.currentState.encoded()["maxLeft"] == 90.0


async def test_moves_before_homing_are_refused(kemar: Kemar) -> None:
    for service, inputs in [("MoveAbsolutePosition", {"target": 10}), ("MoveRelativePosition", {"target": 5}),
                            ("ControlInSpeed", {"velocity": 20})]:
        refused = await kemar.send(service, inputs)
        assert refused.status == "error"
        assert refused.exception == {
            "ex": "::kemar::NOT_HOMED", "detail": {"message": "the head is not homed: call Homing first"}}
        assert NOT_HOMED.ex_id("kemar") == refused.exception["ex"]
    assert kemar.requests.running() == []


async def test_absolute_relative_and_get_position(homed: Kemar) -> None:
    assert (await call(homed, "MoveAbsolutePosition", {"target": 20})).status == "done"
    assert (await call(homed, "MoveRelativePosition", {"target": 25})).status == "done"
    position = await call(homed, "GetPosition")
    assert position.output is not None
    assert position.output["position"] == pytest.approx(45.0, abs=0.1)
    assert homed.currentState.read().position == pytest.approx(45.0, abs=0.1)


async def test_far_target_stops_half_a_degree_inside_the_limit(homed: Kemar, host: ComponentHost) -> None:
    assert (await call(homed, "MoveAbsolutePosition", {"target": 120, "velocity": 300})).status == "done"
    assert rig(host).head_azimuth == pytest.approx(89.5, abs=0.1)
    assert not rig(host).snapshot().forward_limit


async def test_control_in_speed_stops_before_the_limit(homed: Kemar, host: ComponentHost) -> None:
    request = await call(homed, "ControlInSpeed", {"velocity": -50})
    assert request.status == "done"
    assert rig(host).head_azimuth == pytest.approx(-87.0, abs=0.1)
    assert homed.currentState.read().speed == 0.0


async def test_control_in_speed_zero_stops_the_head(homed: Kemar, host: ComponentHost, clock: VirtualClock) -> None:
    turning = await homed.send("ControlInSpeed", {"velocity": 50})
    await wait_azimuth(host, clock, 20.0)
    stop = await call(homed, "ControlInSpeed", 0)  # a bare value for a one-parameter service
    assert stop.status == "done"
    await finish(turning)
    assert turning.status == "error"
    assert turning.exception == {"ex": "::genom::interrupted", "detail": {"by": "ControlInSpeed"}}
    snapshot = rig(host).snapshot()
    assert snapshot.velocity == 0.0 and 20.0 < snapshot.azimuth < 80.0


async def test_a_new_move_interrupts_the_running_one(homed: Kemar, host: ComponentHost, clock: VirtualClock) -> None:
    first = await homed.send("MoveAbsolutePosition", {"target": 80, "velocity": 50})
    await wait_azimuth(host, clock, 10.0)
    second = await call(homed, "MoveAbsolutePosition", {"target": -30})
    await finish(first)
    assert first.status == "error"
    assert first.exception == {"ex": "::genom::interrupted", "detail": {"by": "MoveAbsolutePosition"}}
    assert second.status == "done"
    assert rig(host).head_azimuth == pytest.approx(-30.0, abs=0.1)


async def test_abort_stops_the_head(homed: Kemar, host: ComponentHost, clock: VirtualClock) -> None:
    move = await homed.send("MoveAbsolutePosition", {"target": -80, "velocity": 40})
    await wait_azimuth(host, clock, 10.0)
    await homed.abort(move.id)
    assert move.status == "error"
    await clock.sleep(0.2)
    assert rig(host).snapshot().velocity == 0.0
    assert -80.0 < rig(host).head_azimuth < -10.0


async def test_latched_fault_ends_the_move_in_error_and_homing_recovers(homed: Kemar, host: ComponentHost,
                                                                       clock: VirtualClock) -> None:
    move = await homed.send("MoveAbsolutePosition", {"target": 70})
    await wait_azimuth(host, clock, 10.0)
    rig(host).inject_fault(MotorFault.POSITION_TRACKING, 0x8611)
    await finish(move)
    assert move.status == "error"
    assert move.exception is not None and move.exception["ex"] == "::kemar::DRIVE_FAULT"
    assert "position tracking error" in move.exception["detail"]["message"]
    refused = await call(homed, "MoveAbsolutePosition", {"target": 0})
    assert refused.exception is not None and refused.exception["ex"] == "::kemar::DRIVE_FAULT"
    assert (await call(homed, "Homing")).status == "done"
    assert (await call(homed, "MoveAbsolutePosition", {"target": 12})).status == "done"


async def test_silent_drive_gives_bus_timeouts_and_homing_recovers(homed: Kemar, host: ComponentHost) -> None:
    homed.head().driver.timeout = 0.2  # the tests' generous bound would only make this wait longer
    rig(host).set_silent(True)
    move = await call(homed, "MoveAbsolutePosition", {"target": 30})
    assert move.exception is not None and move.exception["ex"] == "::kemar::BUS_TIMEOUT"
    assert "did not answer" in move.exception["detail"]["message"]
    position = await call(homed, "GetPosition")
    assert position.exception is not None and position.exception["ex"] == "::kemar::BUS_TIMEOUT"
    rig(host).set_silent(False)
    assert (await call(homed, "Homing")).status == "done"
    assert (await call(homed, "MoveAbsolutePosition", {"target": -12})).status == "done"


async def test_set_velocity_is_checked(homed: Kemar) -> None:
    assert (await call(homed, "SetVelocity", {"velocity": 300})).status == "done"
    assert homed.head().speed == 300.0
    bad = await call(homed, "SetVelocity", {"velocity": 5000})
    assert bad.exception is not None and bad.exception["ex"] == "::kemar::INVALID_VELOCITY"
    refused = await homed.send("MoveAbsolutePosition", {"target": 10, "velocity": -3})
    assert refused.exception is not None and refused.exception["ex"] == "::kemar::INVALID_VELOCITY"
    assert refused.exception["detail"]["velocity"] == -3.0


async def test_current_position_publishes_until_stopped(homed: Kemar) -> None:
    watcher = await homed.send("CurrentPosition")
    version = homed.currentState.version
    await homed.currentState.wait_published(version + 3)
    stop = await call(homed, "StopCurrentPosition")
    assert stop.status == "done"
    await finish(watcher)
    assert watcher.exception == {"ex": "::genom::interrupted", "detail": {"by": "StopCurrentPosition"}}


async def test_the_rig_is_shared_and_closed_with_the_host(clock: VirtualClock) -> None:
    async with ComponentHost(clock=clock, settings=HostSettings(can="virtual"), factories={"kemar": Kemar}) as host:
        kemar = await host.load("kemar")
        drive = rig(host)
        assert host.shared(SimulatedHarmonica, lambda: SimulatedHarmonica()) is drive  # one per host
        head = host.require(HeadAzimuth)  # what the sound scene follows
        assert (await call(kemar, "Homing")).status == "done"
        assert (await call(kemar, "MoveAbsolutePosition", {"target": -25})).status == "done"
        assert head.read() == drive.head_azimuth == pytest.approx(-25.0, abs=0.1)
    assert drive.closed
    assert host.find(HeadAzimuth) is None  # withdrawn with the instance


@pytest.mark.parametrize("setting", ["socketcan:no-such-can", "nonsense"])
async def test_a_bad_bus_ends_requests_with_bus_error(clock: VirtualClock, setting: str) -> None:
    async with ComponentHost(clock=clock, settings=HostSettings(can=setting), factories={"kemar": Kemar}) as host:
        kemar = await host.load("kemar")
        assert simulated_rig(host) is None
        request = await call(kemar, "GetPosition")
        assert request.exception is not None and request.exception["ex"] == "::kemar::BUS_ERROR"
        assert "CAN bus" in request.exception["detail"]["message"]


def test_parse_bus() -> None:
    assert parse_bus("virtual") == ("virtual", None)
    assert parse_bus("socketcan:can0") == ("socketcan", "can0")
    assert parse_bus("pcan:PCAN_USBBUS1") == ("pcan", "PCAN_USBBUS1")
    with pytest.raises(BusError):
        parse_bus("can0")


async def test_a_move_beyond_a_limit_says_so(kemar: Kemar) -> None:
    """Issue 13: a target out of reach ends done at the limit, and the output says it was limited."""
    homing = await kemar.send("Homing")
    await homing.ended.wait()
    beyond = await kemar.send("MoveAbsolutePosition", {"target": 120.0, "velocity": 200.0})
    await beyond.ended.wait()
    assert beyond.status == "done" and beyond.output is not None
    assert beyond.output["limited"] and 89.0 < beyond.output["position"] < 90.0
    within = await kemar.send("MoveRelativePosition", {"target": -30.0, "velocity": 200.0})
    await within.ended.wait()
    assert within.output is not None and not within.output["limited"]
    assert abs(within.output["position"] - (beyond.output["position"] - 30.0)) < 0.1
