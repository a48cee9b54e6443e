"""The asyncio driver against the simulated drive: matching, errors, time-outs, SDO, EMCY, closing."""

from __future__ import annotations

import asyncio

import can
import pytest

from aiogenomix.components.kemar import (
    BusError, DriveCommandError, DriveTimeout, Emergency, HarmonicaDriver, MotorFault, NmtCommand, SdoAbortError,
    SimulatedHarmonica,
)
from aiogenomix.components.kemar._codec import encode_set


@pytest.fixture
async def started(driver: HarmonicaDriver) -> HarmonicaDriver:
    await driver.nmt(NmtCommand.START)
    await driver.status()  # NMT has no reply: a query proves the drive is operational
    return driver


async def test_pdos_are_ignored_until_nmt_start(driver: HarmonicaDriver) -> None:
    driver.timeout = 0.05
    with pytest.raises(DriveTimeout, match="did not answer query PX"):
        await driver.query("PX")
    await driver.nmt(NmtCommand.START)
    assert await driver.query("PX") == 0


async def test_set_returns_the_echo_and_query_reads_it_back(started: HarmonicaDriver) -> None:
    assert await started.set("SP", 20480) == 20480
    assert await started.query("SP") == 20480
    assert await started.set("TR", 15, 1) == 15
    assert await started.query_int("TR", 2) == 200


async def test_float_query(started: HarmonicaDriver) -> None:
    current = await started.query("IQ")
    assert isinstance(current, float)


async def test_concurrent_queries_get_their_own_replies(started: HarmonicaDriver) -> None:
    await started.set("SP", 1111)
    await started.set("AC", 2222)
    await started.set("DC", 3333)
    results = await asyncio.gather(*(started.query(m) for m in ["SP", "AC", "DC", "SP", "AC", "DC"] * 10))
    assert results == [1111, 2222, 3333] * 20


async def test_error_reply_raises_with_the_error_code(started: HarmonicaDriver) -> None:
    with pytest.raises(DriveCommandError) as caught:
        await started.execute("BG")
    assert (caught.value.mnemonic, caught.value.code) == ("BG", 58)
    assert "motor must be on" in str(caught.value)
    assert await started.query("EC") == 58
    with pytest.raises(DriveCommandError, match="bad command"):
        await started.query("ZZ")
    with pytest.raises(DriveCommandError, match="bad index"):
        await started.query("HM", 9)


async def test_silent_drive_times_out_and_the_driver_keeps_working(started: HarmonicaDriver,
                                                                  sim: SimulatedHarmonica) -> None:
    started.timeout = 0.05
    sim.set_silent(True)
    with pytest.raises(DriveTimeout):
        await started.query("PX")
    sim.set_silent(False)
    assert await started.query("PX") == 0


async def test_sdo_download_upload_and_abort(started: HarmonicaDriver) -> None:
    await started.sdo_download(0x1016, 1, 0x007F0064)
    assert await started.sdo_upload(0x1016, 1) == 0x007F0064
    with pytest.raises(SdoAbortError, match="does not exist"):
        await started.sdo_upload(0x1234, 0)
    with pytest.raises(SdoAbortError, match="sub-index"):
        await started.sdo_download(0x1A00, 9, 1)


async def test_emergency_is_decoded_latched_and_passed_to_listeners(started: HarmonicaDriver,
                                                                   sim: SimulatedHarmonica) -> None:
    received: asyncio.Queue[Emergency] = asyncio.Queue()
    started.add_emergency_listener(received.put_nowait)
    sim.inject_fault(MotorFault.MOTOR_STUCK, 0x7121)
    emergency = await asyncio.wait_for(received.get(), 2)
    assert emergency.error_code == 0x7121
    assert started.latched_emergency == emergency
    assert started.emergencies[-1] == emergency
    status = await started.status()
    assert status.motor_fault and not status.motor_on
    assert await started.query("MF") == MotorFault.MOTOR_STUCK
    started.clear_emergency()
    assert started.latched_emergency is None


async def test_unsolicited_and_malformed_replies_are_counted(started: HarmonicaDriver, sim: SimulatedHarmonica) -> None:
    with can.Bus(interface="virtual", channel=sim.channel) as intruder:
        for data in (encode_set("VX", 5), b"\x01\x02"):
            intruder.send(can.Message(arbitration_id=started.cob.interpreter_reply, data=data, is_extended_id=False))
    # The reply to this query is delivered after both frames, so they have been dispatched by then.
    assert await started.query("PX") == 0
    assert started.unmatched_frames == 2


async def test_close_is_idempotent_and_fails_new_requests(sim: SimulatedHarmonica) -> None:
    driver = HarmonicaDriver.open("virtual", sim.channel)
    driver.start()
    await driver.aclose()
    await driver.aclose()
    assert driver.closed
    with pytest.raises(BusError):
        await driver.query("PX")


async def test_close_fails_a_pending_request(sim: SimulatedHarmonica) -> None:
    sim.set_silent(True)
    driver = HarmonicaDriver.open("virtual", sim.channel, timeout=5.0)
    driver.start()
    with can.Bus(interface="virtual", channel=sim.channel) as spy:
        pending = asyncio.create_task(driver.query("PX"))
        # The request is on the bus (and unanswered) once the spy sees it.
        assert await asyncio.to_thread(spy.recv, 5.0) is not None
    await driver.aclose()
    with pytest.raises(BusError, match="closed"):
        await pending


async def test_unstarted_driver_refuses_requests(sim: SimulatedHarmonica) -> None:
    driver = HarmonicaDriver.open("virtual", sim.channel)
    try:
        with pytest.raises(BusError, match="not started"):
            await driver.query("PX")
    finally:
        await driver.aclose()


def test_open_reports_a_bus_that_does_not_exist() -> None:
    with pytest.raises(BusError, match="cannot open CAN bus"):
        HarmonicaDriver.open("no-such-interface", "can0")
