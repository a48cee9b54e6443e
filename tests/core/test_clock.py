"""Clocks: a stepped clock wakes sleepers in order; a scaled clock runs faster than real time; virtual time."""

from __future__ import annotations

import asyncio
import threading
import time

import pytest

from aiogenomix.components.core import ManualClock, ScaledClock, VirtualClock


async def test_manual_clock_wakes_sleepers_in_deadline_order() -> None:
    clock = ManualClock()
    woken: list[tuple[str, float]] = []

    async def sleeper(name: str, delay: float) -> None:
        await clock.sleep(delay)
        woken.append((name, clock.now()))

    tasks = [asyncio.create_task(sleeper(n, d)) for n, d in [("late", 3.0), ("early", 1.0), ("mid", 2.0)]]
    await clock.advance(1.5)
    assert woken == [("early", 1.0)]
    await clock.advance(2.0)
    assert woken == [("early", 1.0), ("mid", 2.0), ("late", 3.0)]
    assert clock.now() == 3.5
    await asyncio.gather(*tasks)


async def test_scaled_clock_runs_faster_than_real_time() -> None:
    clock = ScaledClock(100)
    started_real, started = time.monotonic(), clock.now()
    await clock.sleep(2.0)
    assert clock.now() - started >= 2.0
    assert time.monotonic() - started_real < 1.0
    assert abs(clock.wall() - time.time()) < 100 * (time.monotonic() - started_real) + 1


def test_scaled_clock_refuses_nonsense() -> None:
    with pytest.raises(ValueError):
        ScaledClock(0)


def _answer_from_a_thread(clock: ManualClock, delay: float) -> asyncio.Future[float]:
    """A device served by a thread: it answers, after *delay* real seconds, the clock time it was asked at."""
    loop = asyncio.get_running_loop()
    future: asyncio.Future[float] = loop.create_future()
    asked = clock.now()
    threading.Timer(delay, lambda: loop.call_soon_threadsafe(future.set_result, asked)).start()
    return future


async def _poll(clock: ManualClock, period: float, until: float, device_delay: float) -> list[tuple[float, float]]:
    """A controller polling the device: (when it asked, what the device said), each period."""
    seen = []
    while clock.now() < until:
        with clock.holding():
            answer = await _answer_from_a_thread(clock, device_delay)
        seen.append((clock.now(), answer))
        await clock.sleep(period)
    return seen


async def test_held_time_waits_for_a_device_answering_from_a_thread() -> None:
    clock = ManualClock()
    # However slowly the device answers in real time, it answers at the instant it was asked.
    seen = await clock.run_until(_poll(clock, 0.25, 1.0, device_delay=0.02))
    assert seen == [(0.0, 0.0), (0.25, 0.25), (0.5, 0.5), (0.75, 0.75)]
    assert clock.now() == 1.0


async def test_run_until_gives_up_after_its_limit_of_clock_time() -> None:
    clock = ManualClock()

    async def forever() -> None:
        while True:
            await clock.sleep(1.0)

    with pytest.raises(TimeoutError, match="not done after 10"):
        await clock.run_until(forever(), limit=10.0)
    assert clock.now() == 10.0


async def test_virtual_clock_jumps_from_deadline_to_deadline_whatever_the_load() -> None:
    clock = VirtualClock()
    started = time.monotonic()
    woken: list[tuple[str, float]] = []

    async def sleeper(name: str, delay: float, times: int) -> None:
        for _ in range(times):
            await clock.sleep(delay)
            woken.append((name, clock.now()))

    await asyncio.gather(sleeper("slow", 30.0, 2), sleeper("fast", 20.0, 3), _poll(clock, 10.0, 40.0, 0.01))
    assert time.monotonic() - started < 5  # a minute of clock time, without waiting for it
    assert woken == [("fast", 20.0), ("slow", 30.0), ("fast", 40.0), ("slow", 60.0), ("fast", 60.0)]
    await clock.aclose()


async def test_virtual_clock_runs_no_faster_than_its_scale() -> None:
    clock = VirtualClock(scale=20.0)
    started = time.monotonic()
    await clock.sleep(2.0)  # 2 s of clock time at 20x: a tenth of a second
    assert clock.now() == 2.0
    assert time.monotonic() - started >= 0.09
    await clock.aclose()
    with pytest.raises(ValueError):
        VirtualClock(scale=0)
