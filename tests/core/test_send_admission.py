"""Admission of a request at send: refusals end the request, and interruption is decided atomically.

Bursts of sends that interrupt each other must leave exactly one activity
running, whatever the interleaving, with every other request ending
``interrupted`` once and a stop path that is never cut short.
"""

from __future__ import annotations

import asyncio
import logging
import random
from collections import Counter
from collections.abc import AsyncIterator
from typing import Annotated, Any

import pytest

from aiogenomix.components.core import (
    Component, ComponentHost, Double, GenomException, Long, ManualClock, activity, function,
)
from aiogenomix.components.core.runtime import Request
from aiogenomix.components.demo import Demo


class Recorder:
    """Collects the request events of a host; lets a test await the end of a request."""

    def __init__(self) -> None:
        self.events: list[dict[str, Any]] = []
        self._changed = asyncio.Event()

    def __call__(self, request: Request) -> None:
        self.events.append(request.status_object())
        self._changed.set()

    def finals(self) -> Counter[str]:
        """How many final (done or error) events each request id had."""
        return Counter(e["id"] for e in self.events if e["status"] != "sent")

    async def ended(self, request_id: str) -> None:
        """Wait for the final event of *request_id*."""
        while not self.finals()[request_id]:
            self._changed.clear()
            await self._changed.wait()


class WRONG_WAY(GenomException):
    """A turn the other way round is refused."""


class Turntable(Component, name="turntable"):
    """A turntable: each turn interrupts the one under way, whose stop path brakes until released."""

    async def on_start(self) -> None:
        self.turning = asyncio.Event()
        self.braking = asyncio.Event()
        self.brakes_released = asyncio.Event()
        self.brakes_released.set()
        self.stop_paths = 0

    async def _check(self, angle: float, checks: int = 0) -> None:
        # An asynchronous validate taking *checks* loop turns: in a burst, validations end in any order.
        for _ in range(checks):
            await asyncio.sleep(0)
        if angle < 0:
            raise WRONG_WAY()

    @activity(interrupts=("Turn",), throws=(WRONG_WAY,), validate=_check)
    async def Turn(self, angle: Annotated[Double, "Where to"] = 0.0,
                   checks: Annotated[Long, "Loop turns its validate takes"] = 0) -> None:
        """Turn until interrupted."""
        self.turning.set()
        try:
            await asyncio.Event().wait()
        finally:
            # A stop path that takes time: a second cancellation here would leave the table spinning.
            self.braking.set()
            await self.brakes_released.wait()
            self.stop_paths += 1

    @function(interrupts=("Turn",))
    def Halt(self) -> None:
        """Stop turning."""

    def _buggy(self) -> None:
        raise ZeroDivisionError("division by zero")

    @activity(validate=_buggy)
    async def Fragile(self) -> None:
        """Never starts: its validate has a bug."""


@pytest.fixture
async def table_host() -> AsyncIterator[tuple[ComponentHost, Recorder]]:
    recorder = Recorder()
    async with ComponentHost(clock=ManualClock(), factories={"turntable": Turntable, "demo": Demo},
                             function_grace=0.01) as host:
        host.add_request_listener(recorder)
        yield host, recorder
        for component in host.instances.values():
            if isinstance(component, Turntable):
                component.brakes_released.set()  # even after a failed test, so that closing ends


def running_activities(component: Component) -> list[dict[str, Any]]:
    """The activities ``genom_state`` lists, over all tasks."""
    return [a for task in component.genom_state.encoded()["task"] for a in task["activity"]]


@pytest.mark.parametrize("seed", range(6))
async def test_a_burst_of_turns_leaves_exactly_one_running(table_host: tuple[ComponentHost, Recorder],
                                                           seed: int) -> None:
    host, recorder = table_host
    table = await host.load("turntable")
    rng = random.Random(seed)

    async def send(i: int) -> Request:
        # Vary the interleaving: each send starts after a few loop turns, its validate takes a few more.
        for _ in range(rng.randrange(3)):
            await asyncio.sleep(0)
        return await table.send("Turn", {"angle": i, "checks": rng.randrange(4)}, session="s")

    requests = await asyncio.gather(*(send(i) for i in range(20)))

    assert len(table.requests.running()) == 1
    (survivor,) = table.requests.running()
    assert running_activities(table) == [{"id": survivor.number, "name": "Turn"}]
    others = [r for r in requests if r is not survivor]
    assert all(r.exception == {"ex": "::genom::interrupted", "detail": {"by": "Turn"}} for r in others)
    assert recorder.finals() == Counter(r.id for r in others)  # one final event each
    await table.send("Halt", session="s")
    assert not table.requests.running() and survivor.status == "error"
    assert recorder.finals() == Counter(r.id for r in requests) + Counter(["turntable::20"])


@pytest.mark.parametrize("seed", range(3))
async def test_a_burst_of_moves_and_gotos_leaves_one_motion(table_host: tuple[ComponentHost, Recorder],
                                                            seed: int) -> None:
    host, recorder = table_host
    demo = await host.load("demo")
    rng = random.Random(seed)
    services = [("GotoPosition", {"posRef": 0.5}), ("MoveDistance", {"distRef": -0.25})]
    requests = await asyncio.gather(*(demo.send(*rng.choice(services), session="s") for _ in range(20)))

    assert len(running_activities(demo)) == 1
    (survivor,) = demo.requests.running()
    assert recorder.finals() == Counter(r.id for r in requests if r is not survivor)
    clock = host.clock
    assert isinstance(clock, ManualClock)
    await clock.advance(10)  # the one motion runs to its end, alone
    assert survivor.status == "done"
    assert demo.Mobile.read().position in (0.5, -0.25)


async def test_a_stop_path_is_never_cut_short_and_an_unstarted_turn_never_runs(
        table_host: tuple[ComponentHost, Recorder]) -> None:
    host, recorder = table_host
    table = await host.load("turntable")
    first = await table.send("Turn", {"angle": 1}, session="s")
    await table.turning.wait()
    table.turning.clear()
    table.brakes_released.clear()

    second_send = asyncio.create_task(table.send("Turn", {"angle": 2}, session="s"))
    await table.braking.wait()                  # first was told to stop; second waits for its stop path
    third_send = asyncio.create_task(table.send("Turn", {"angle": 3}, session="s"))
    await recorder.ended("turntable::1")        # third interrupted second, which had not started
    assert first.running and table.stop_paths == 0   # first still brakes: it was cancelled only once

    table.brakes_released.set()
    second, third = await second_send, await third_send
    assert first.exception == {"ex": "::genom::interrupted", "detail": {"by": "Turn"}}
    assert second.exception == {"ex": "::genom::interrupted", "detail": {"by": "Turn"}}
    assert table.stop_paths == 1                # second's body never ran: no stop path of its own
    assert third.running and table.requests.running() == [third]
    await table.turning.wait()
    assert recorder.finals() == Counter({"turntable::0": 1, "turntable::1": 1})


async def test_abort_of_a_request_waiting_for_its_victim(table_host: tuple[ComponentHost, Recorder]) -> None:
    host, recorder = table_host
    table = await host.load("turntable")
    first = await table.send("Turn", {"angle": 1}, session="s")
    await table.turning.wait()
    table.brakes_released.clear()
    second_send = asyncio.create_task(table.send("Turn", {"angle": 2}, session="s"))
    await table.braking.wait()
    aborted = await table.abort("turntable::1")
    assert aborted.exception == {"ex": "::genom::interrupted", "detail": {"by": "abort"}}
    table.brakes_released.set()
    assert await second_send is aborted
    await first.ended.wait()
    assert table.requests.running() == [] and running_activities(table) == []
    assert recorder.finals() == Counter({"turntable::0": 1, "turntable::1": 1})


async def test_validate_refusals_and_bugs_end_the_request(table_host: tuple[ComponentHost, Recorder],
                                                          caplog: pytest.LogCaptureFixture) -> None:
    host, recorder = table_host
    table = await host.load("turntable")
    turning = await table.send("Turn", {"angle": 1}, session="s")
    refused = await table.send("Turn", {"angle": -1, "checks": 2}, session="s")
    assert refused.status_object() == {"id": "turntable::1", "status": "error",
                                       "exception": {"ex": "::turntable::WRONG_WAY"}}
    assert turning.running  # a refused turn interrupts nothing
    with caplog.at_level(logging.ERROR):
        fragile = await table.send("Fragile", session="s")
    assert fragile.exception == {"ex": "::genom::unkex",
                                 "detail": {"what": "ZeroDivisionError: division by zero"}}
    assert "division by zero" in caplog.text  # a bug in validate is reported, not a 500
    assert recorder.finals() == Counter({"turntable::1": 1, "turntable::2": 1})
