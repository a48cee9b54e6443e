"""The head logic on the simulated drive: homing, moves, clamping, velocity control, faults and recovery."""

from __future__ import annotations

import asyncio

import pytest

from aiogenomix.components.core import VirtualClock
from aiogenomix.components.kemar import (
    COUNTS_PER_DEGREE, DriveFault, DriveTimeout, HarmonicaDriver, HeadConfig, HeadState, HomingFailed,
    InvalidCommand, KemarHead, MotionTimeout, MotorFault, NotHomed, SimulatedHarmonica,
)

COUNT = 1 / COUNTS_PER_DEGREE  # one encoder count, in degrees


async def test_homing_finds_both_limits_and_centres_the_head(head: KemarHead, sim: SimulatedHarmonica) -> None:
    state = await head.home()
    assert head.homed
    assert (head.max_left, head.max_right) == (90.0, -90.0)
    assert abs(state.position) <= 4 * COUNT
    assert abs(sim.head_azimuth) <= 4 * COUNT
    assert head.speed == 100.0
    snapshot = sim.snapshot()
    assert snapshot.motor_on and snapshot.unit_mode == 5 and snapshot.position == 0


async def test_homing_from_an_offset_start_with_asymmetric_switches(clock: VirtualClock) -> None:
    async with SimulatedHarmonica(clock=clock, start_azimuth=-70.0, limits=(-80.0, 86.0)) as sim, \
            HarmonicaDriver.open("virtual", sim.channel) as driver:
        head = KemarHead(driver, clock)
        await head.home()
        assert head.max_left == pytest.approx(83.0, abs=COUNT)
        assert head.max_right == pytest.approx(-83.0, abs=COUNT)
        assert sim.head_azimuth == pytest.approx(3.0, abs=4 * COUNT)  # the physical midpoint


async def test_homing_starting_on_the_forward_switch(clock: VirtualClock) -> None:
    async with SimulatedHarmonica(clock=clock, start_azimuth=89.99) as sim, \
            HarmonicaDriver.open("virtual", sim.channel) as driver:
        head = KemarHead(driver, clock)
        await head.home()  # homing first leaves the switch: its event fires on the rising edge only
        assert abs(sim.head_azimuth) <= 4 * COUNT
        assert head.max_left == pytest.approx(90.0, abs=COUNT)


async def test_homing_gives_up_when_a_switch_is_out_of_reach(driver: HarmonicaDriver, clock: VirtualClock) -> None:
    # 90 deg at 1 deg/s takes 90 s: far out of reach of the 1 s allowed, even if the process stalls
    # (at 48.8 deg/s, 1.8 s, a stall of 8 ms of real time let the head reach the switch in time).
    head = KemarHead(driver, clock, HeadConfig(homing_timeout=1.0, homing_speed=round(COUNTS_PER_DEGREE)))
    with pytest.raises(HomingFailed, match="forward .* not reached within 1 s"):
        await head.home()
    assert not head.homed


async def test_moves_need_homing(head: KemarHead) -> None:
    for move in (head.move_absolute(10), head.move_relative(10), head.control_in_speed(10)):
        with pytest.raises(NotHomed, match="call Homing first"):
            await move


async def test_absolute_and_relative_moves(homed_head: KemarHead, sim: SimulatedHarmonica) -> None:
    state = await homed_head.move_absolute(20.0)
    assert state.position == pytest.approx(20.0, abs=0.1)
    state = await homed_head.move_relative(25.0)
    assert state.position == pytest.approx(45.0, abs=0.1)
    assert sim.head_azimuth == pytest.approx(45.0, abs=0.1)
    state = await homed_head.move_relative(-60.0, speed=300.0)
    assert state.position == pytest.approx(-15.0, abs=0.1)


@pytest.mark.parametrize(("target", "expected"), [(120.0, 89.5), (-95.0, -89.5), (89.9, 89.5)])
async def test_targets_are_clamped_half_a_degree_inside_the_limits(homed_head: KemarHead,
                                                                  sim: SimulatedHarmonica,
                                                                  target: float, expected: float) -> None:
    state = await homed_head.move_absolute(target)
    assert state.position == pytest.approx(expected, abs=0.1)
    snapshot = sim.snapshot()
    assert not snapshot.forward_limit and not snapshot.reverse_limit


async def test_relative_targets_are_clamped_too(homed_head: KemarHead) -> None:
    await homed_head.move_absolute(80.0)
    state = await homed_head.move_relative(30.0)
    assert state.position == pytest.approx(89.5, abs=0.1)


async def test_set_speed_is_checked_and_used(homed_head: KemarHead) -> None:
    homed_head.set_speed(250.0)
    assert homed_head.speed == 250.0
    for bad in (0.0, -5.0, 2000.0):
        with pytest.raises(InvalidCommand):
            homed_head.set_speed(bad)
    with pytest.raises(InvalidCommand):
        await homed_head.control_in_speed(5000.0)


async def test_a_cancelled_move_stops_the_head_and_a_new_one_goes_to_its_target(homed_head: KemarHead,
                                                                                sim: SimulatedHarmonica,
                                                                                clock: VirtualClock) -> None:
    first = asyncio.create_task(homed_head.move_absolute(80.0, speed=50.0))
    while sim.head_azimuth < 10.0:
        await clock.sleep(0.05)
    first.cancel()
    with pytest.raises(asyncio.CancelledError):
        await first
    stopped = sim.head_azimuth
    assert 10.0 <= stopped < 80.0
    state = await homed_head.move_absolute(-30.0)
    assert state.position == pytest.approx(-30.0, abs=0.1)


async def test_velocity_control_then_zero_stops(homed_head: KemarHead, sim: SimulatedHarmonica,
                                                clock: VirtualClock) -> None:
    turning = asyncio.create_task(homed_head.control_in_speed(-40.0))
    while sim.head_azimuth > -20.0:
        await clock.sleep(0.05)
    turning.cancel()
    with pytest.raises(asyncio.CancelledError):
        await turning
    state = await homed_head.control_in_speed(0.0)
    assert state.speed == 0.0
    assert -60.0 < state.position < -20.0
    assert sim.snapshot().velocity == 0.0
    # The position-control speed is not changed by velocity control.
    assert homed_head.speed == 100.0


async def test_velocity_control_from_beyond_the_stop_point_does_not_move(homed_head: KemarHead) -> None:
    await homed_head.move_absolute(88.0)
    state = await homed_head.control_in_speed(30.0)
    assert state.position == pytest.approx(88.0, abs=0.1)


async def test_states_are_published(homed_head: KemarHead) -> None:
    seen: list[HeadState] = []
    homed_head.on_state = seen.append
    arrived = await homed_head.move_absolute(10.0)
    # Every state read during the move is published, the arrival last. How many reads the move takes
    # depends on the machine's load (it lasts about 1 ms of real time): what they show does not.
    assert seen and seen[-1] == arrived
    assert arrived.position == pytest.approx(10.0, abs=0.1)
    assert all((s.max_left, s.max_right) == (90.0, -90.0) for s in seen)
    assert all(-0.1 <= s.position <= 10.1 for s in seen)
    assert [s.timestamp for s in seen] == sorted(s.timestamp for s in seen)
    # A state read outside a move is published too.
    assert await homed_head.read_state() == seen[-1] and len(seen) >= 2


async def test_latched_fault_during_a_move_then_homing_recovers(homed_head: KemarHead, sim: SimulatedHarmonica,
                                                               clock: VirtualClock) -> None:
    move = asyncio.create_task(homed_head.move_absolute(-80.0))
    while sim.head_azimuth > -10.0:
        await clock.sleep(0.02)
    sim.inject_fault(MotorFault.POSITION_TRACKING, 0x8611)
    with pytest.raises(DriveFault, match="position tracking error") as caught:
        await move
    assert caught.value.motor_fault == MotorFault.POSITION_TRACKING
    with pytest.raises(DriveFault):  # still latched
        await homed_head.move_absolute(0.0)
    await homed_head.home()
    state = await homed_head.move_absolute(15.0)
    assert state.position == pytest.approx(15.0, abs=0.1)


async def test_stuck_motor_ends_the_move_with_a_fault(homed_head: KemarHead, sim: SimulatedHarmonica) -> None:
    sim.set_stuck(True)
    with pytest.raises(DriveFault, match="motor stuck"):
        await homed_head.move_absolute(40.0)
    sim.set_stuck(False)
    await homed_head.home()
    assert (await homed_head.move_absolute(5.0)).position == pytest.approx(5.0, abs=0.1)


async def test_a_dragging_motor_is_stopped_at_the_move_deadline(homed_head: KemarHead, sim: SimulatedHarmonica) -> None:
    # The drive reports a normal move, only slow: the head's own deadline (twice the planned time,
    # plus a second) must end it and stop the motor, not wait for an arrival that may never come.
    sim.set_drag(0.1)
    with pytest.raises(MotionTimeout, match="did not end within"):
        await homed_head.move_absolute(40.0)
    stopped = await homed_head.control_in_speed(0.0)  # returns once the drive says it stands
    assert stopped.speed == 0 and 0.0 < stopped.position < 40.0
    assert sim.head_azimuth == pytest.approx(stopped.position, abs=0.1)
    sim.set_drag(1.0)
    assert (await homed_head.move_absolute(5.0)).position == pytest.approx(5.0, abs=0.1)


async def test_silent_drive_times_out_then_homing_recovers(homed_head: KemarHead, sim: SimulatedHarmonica) -> None:
    homed_head.driver.timeout = 0.1
    sim.set_silent(True)
    with pytest.raises(DriveTimeout, match="did not answer"):
        await homed_head.move_absolute(30.0)
    with pytest.raises(DriveTimeout):
        await homed_head.read_position()
    sim.set_silent(False)
    await homed_head.home()
    assert (await homed_head.move_absolute(-5.0)).position == pytest.approx(-5.0, abs=0.1)
