"""Clocks: a stepped clock wakes sleepers in order; a scaled clock runs faster than real time."""

from __future__ import annotations

import asyncio
import time

import pytest

from aiogenomix.components.core import ManualClock, ScaledClock


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
