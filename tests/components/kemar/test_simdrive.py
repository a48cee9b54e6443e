"""The simulated Harmonica: limit switches, homing-on-the-fly, error codes, faults, NMT, CLI."""

from __future__ import annotations

import asyncio
import subprocess
import sys
import threading

import pytest

from aiogenomix.components.core import VirtualClock
from aiogenomix.components.kemar import (
    COUNTS_PER_DEGREE, DriveCommandError, HarmonicaDriver, MotorFault, NmtCommand, NmtState, SimulatedHarmonica,
)
from aiogenomix.components.kemar._codec import INPUT_FORWARD_LIMIT, INPUT_REVERSE_LIMIT

FLS = round(90 * COUNTS_PER_DEGREE)


@pytest.fixture
async def drive(driver: HarmonicaDriver) -> HarmonicaDriver:
    """The driver, with the drive operational and its motor on in speed mode."""
    await driver.nmt(NmtCommand.START)
    await driver.set("UM", 2)
    await driver.set("MO", 1)
    return driver


async def wait_until_still(driver: HarmonicaDriver, clock: VirtualClock) -> None:
    while await driver.query("VX") != 0 or (await driver.status()).motion_status == 2:
        await clock.sleep(0.02)


async def test_jog_stops_on_the_forward_switch(drive: HarmonicaDriver, sim: SimulatedHarmonica,
                                               clock: VirtualClock) -> None:
    await drive.set("JV", 20000)
    await drive.execute("BG")
    while not await drive.query_int("IP") & INPUT_FORWARD_LIMIT:
        await clock.sleep(0.05)
    await wait_until_still(drive, clock)
    assert sim.head_azimuth == pytest.approx(90.0)
    assert await drive.query("PX") == FLS
    status = await drive.status()
    assert status.stopped_by_limit and status.motor_on
    # Towards the switch is inhibited; away from it is allowed.
    await drive.execute("BG")
    assert (await drive.status()).motion_status != 2
    await drive.set("JV", -20000)
    await drive.execute("BG")
    await clock.sleep(0.2)
    assert not await drive.query_int("IP") & INPUT_FORWARD_LIMIT
    assert not (await drive.status()).stopped_by_limit


async def test_homing_on_the_fly_loads_px_at_the_reverse_switch(drive: HarmonicaDriver,
                                                               clock: VirtualClock) -> None:
    for index, value in ((2, 1000), (3, 7), (4, 0), (5, 0), (1, 1)):
        await drive.set("HM", value, index)
    assert (await drive.status()).homing
    with pytest.raises(DriveCommandError, match="homing is busy"):
        await drive.set("HM", 5, 3)
    await drive.set("JV", -30000)
    await drive.execute("BG")
    while await drive.query("HM", 1) == 1:  # the drive disarms homing when the event fires
        await clock.sleep(0.05)
    await wait_until_still(drive, clock)
    assert await drive.query("PX") == 1000
    assert await drive.query_int("IP") & INPUT_REVERSE_LIMIT


async def test_immediate_homing_event_loads_px_now(drive: HarmonicaDriver) -> None:
    await drive.set("HM", 0, 3)
    await drive.set("HM", -42, 2)
    await drive.set("HM", 1, 1)
    assert await drive.query("PX") == -42
    assert await drive.query("HM", 1) == 0


async def test_position_move_in_position_mode(drive: HarmonicaDriver, sim: SimulatedHarmonica,
                                              clock: VirtualClock) -> None:
    await drive.set("MO", 0)
    await drive.set("UM", 5)
    await drive.set("MO", 1)
    await drive.set("PA", -4096)
    await drive.execute("BG")
    assert (await drive.status()).motion_status == 2
    while (await drive.status()).motion_status != 0:
        await clock.sleep(0.02)
    assert await drive.query("PX") == -4096
    assert sim.head_azimuth == pytest.approx(-20.0)
    await drive.set("PR", 2048)
    await drive.execute("BG")
    await wait_until_still(drive, clock)
    assert await drive.query("PX") == -2048
    assert await drive.query("PA") == -2048


async def test_error_codes(drive: HarmonicaDriver) -> None:
    with pytest.raises(DriveCommandError, match="motor must be off") as caught:
        await drive.set("UM", 5)
    assert caught.value.code == 57
    with pytest.raises(DriveCommandError, match="cannot be assigned"):
        await drive.set("VX", 1)
    with pytest.raises(DriveCommandError, match="out of range"):
        await drive.set("SP", 0)
    await drive.set("MO", 0)
    with pytest.raises(DriveCommandError, match="motor must be on"):
        await drive.execute("BG")
    await drive.set("UM", 1)
    await drive.set("MO", 1)
    with pytest.raises(DriveCommandError, match="bad unit mode"):
        await drive.execute("BG")


async def test_px_cannot_be_set_while_moving(drive: HarmonicaDriver) -> None:
    await drive.set("JV", 1000)
    await drive.execute("BG")
    with pytest.raises(DriveCommandError, match="while moving"):
        await drive.set("PX", 0)


async def test_latched_fault_switches_the_motor_off_until_mo_1(drive: HarmonicaDriver,
                                                               sim: SimulatedHarmonica) -> None:
    await drive.set("JV", 5000)
    await drive.execute("BG")
    sim.inject_fault(MotorFault.PEAK_CURRENT, 0x2340)
    status = await drive.status()
    assert status.motor_fault and not status.motor_on and status.motion_status == 1
    assert await drive.query("MF") == MotorFault.PEAK_CURRENT
    await drive.set("MO", 1)
    assert await drive.query("MF") == 0


async def test_stuck_motor_latches_a_fault_with_an_emergency(drive: HarmonicaDriver, sim: SimulatedHarmonica,
                                                             clock: VirtualClock) -> None:
    sim.set_stuck(True)
    await drive.set("JV", 10000)
    await drive.execute("BG")
    assert (await drive.status()).motion_status == 2
    while drive.latched_emergency is None:
        await clock.sleep(0.05)
    assert drive.latched_emergency.error_code == 0x7121
    assert await drive.query("MF") == MotorFault.MOTOR_STUCK
    assert sim.head_azimuth == 0.0


async def test_head_azimuth_is_readable_from_another_thread(drive: HarmonicaDriver, sim: SimulatedHarmonica,
                                                            clock: VirtualClock) -> None:
    await drive.set("JV", -20480)
    await drive.execute("BG")
    await clock.sleep(0.5)
    seen: list[float] = []
    thread = threading.Thread(target=lambda: seen.extend(sim.head_azimuth for _ in range(100)))
    thread.start()
    await asyncio.to_thread(thread.join)
    assert all(b <= a for a, b in zip(seen, seen[1:], strict=False))  # turning right: the azimuth decreases
    assert -90.0 <= seen[-1] < -40.0


async def test_nmt_reset_node_reboots_the_drive(drive: HarmonicaDriver, clock: VirtualClock) -> None:
    await drive.nmt(NmtCommand.RESET_NODE)
    while drive.nmt_state != NmtState.BOOT_UP:
        await clock.sleep(0.01)
    drive.timeout = 0.05
    await drive.nmt(NmtCommand.START)
    assert await drive.query("MO") == 0  # registers are back to their defaults
    assert await drive.query("UM") == 5


async def test_drive_without_set_echo(clock: VirtualClock) -> None:
    async with SimulatedHarmonica(clock=clock, echo_sets=False) as sim, HarmonicaDriver.open(
        "virtual", sim.channel, expect_set_echo=False
    ) as driver:
        await driver.nmt(NmtCommand.START)
        assert await driver.set("SP", 1234) == 1234
        assert await driver.query("SP") == 1234


def test_start_azimuth_must_lie_between_the_limits() -> None:
    with pytest.raises(ValueError):
        SimulatedHarmonica(start_azimuth=95.0)


def test_cli_serves_a_named_virtual_bus() -> None:
    command = [sys.executable, "-m", "aiogenomix.components.kemar.simdrive", "--interface", "virtual",
               "--channel", "cli-test", "--start-azimuth", "12.5", "--status-period", "0.05"]
    with subprocess.Popen(command, stdout=subprocess.PIPE, text=True) as process:
        assert process.stdout is not None
        try:
            assert "simulated Harmonica node 0x7F on virtual:cli-test" in process.stdout.readline()
            assert process.stdout.readline().startswith("azimuth   +12.50 deg")
        finally:
            process.terminate()
        assert process.wait(timeout=10) == 0
