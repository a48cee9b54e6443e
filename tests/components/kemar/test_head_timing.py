"""Timing of the head on simulated time: move durations and velocity-control stops.

The clock is the conftest's discrete-event one: a move takes the same clock time, and the states
read during it are the same, however busy the machine.  These tests skip homing: the simulated
drive powers up with the head at azimuth 0 and PX = 0, which is the homed frame for switches
at ±90°, so the head is told so directly.
"""

from __future__ import annotations

import pytest

from aiogenomix.components.core import VirtualClock
from aiogenomix.components.kemar import COUNTS_PER_DEGREE, HarmonicaDriver, HeadState, KemarHead, SimulatedHarmonica
from aiogenomix.components.kemar._profile import move_duration

@pytest.fixture
def head(driver: HarmonicaDriver, clock: VirtualClock) -> KemarHead:
    head = KemarHead(driver, clock)
    head.homed, head.max_left, head.max_right = True, 90.0, -90.0
    return head


async def test_move_duration_follows_speed_and_acceleration(head: KemarHead, sim: SimulatedHarmonica,
                                                            clock: VirtualClock) -> None:
    await head.move_absolute(0.0)  # puts the drive in position mode
    speeds: list[float] = []
    head.on_state = lambda state: speeds.append(state.speed)
    started = clock.now()
    state = await head.move_absolute(30.0)
    elapsed = clock.now() - started
    config = head.config
    expected = move_duration(30 * COUNTS_PER_DEGREE, 100 * COUNTS_PER_DEGREE, config.acceleration,
                             config.deceleration)
    assert expected == pytest.approx(0.3683, abs=1e-3)  # 0.2 s cruise + two 68 ms ramps
    assert state.position == pytest.approx(30.0, abs=0.1)
    assert sim.head_azimuth == pytest.approx(30.0, abs=0.1)
    assert expected <= elapsed <= expected + 0.25
    assert max(speeds) == pytest.approx(100.0, abs=0.5)


async def test_a_faster_move_is_shorter(head: KemarHead, clock: VirtualClock) -> None:
    await head.move_absolute(0.0)
    started = clock.now()
    await head.move_absolute(-60.0, speed=400.0)
    elapsed = clock.now() - started
    config = head.config
    expected = move_duration(60 * COUNTS_PER_DEGREE, 400 * COUNTS_PER_DEGREE, config.acceleration,
                             config.deceleration)
    assert expected <= elapsed <= expected + 0.25


@pytest.mark.parametrize("velocity", [50.0, -50.0, 120.0])
async def test_velocity_control_stops_three_degrees_before_the_limit(head: KemarHead, sim: SimulatedHarmonica,
                                                                     velocity: float) -> None:
    states: list[HeadState] = []
    head.on_state = states.append
    state = await head.control_in_speed(velocity)
    limit = 90.0 if velocity > 0 else -90.0
    margin = abs(limit - state.position)
    assert state.speed == 0.0
    assert margin == pytest.approx(3.0, abs=0.1)
    assert abs(limit - sim.head_azimuth) == pytest.approx(margin, abs=0.01)
    assert not sim.snapshot().forward_limit and not sim.snapshot().reverse_limit
    assert max(abs(s.speed) for s in states) == pytest.approx(abs(velocity), abs=0.5)
