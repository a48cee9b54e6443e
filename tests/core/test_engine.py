"""A component's requests are run by its engine, apart from what its author writes (issue 33).

``Winch`` stands for a component of another package whose author named helpers as anyone would:
``_run`` drives the motor, ``_settle`` waits for it, ``_validate`` checks a length, ``service``
greases the drum.  The engine that runs its requests has its own namespace, so none of them is
taken for the engine's (they were, when the component class held the engine), and a host drives
it through ``component.engine`` like any component: sends, interruptions, refusals, ``kill``.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from typing import Annotated

import pytest

from aiogenomix.components.core import (
    Component, ComponentHost, Double, GenomException, ManualClock, Out, OutPort, activity, function, idl_struct,
)
from aiogenomix.components.core.runtime import Request, RequestEngine


class TOO_LONG(GenomException):
    """More rope than the drum holds."""

    limit: Double


@idl_struct("winch::rope")
class Rope:
    """How much rope is out."""

    out: Annotated[Double, "Metres"] = 0.0


def _check_length(winch: Winch, length: float = 1.0) -> None:
    winch._validate(length)


class Winch(Component, name="winch"):
    """A winch that reels rope out, one metre per second of the host's clock."""

    Rope = OutPort(Rope, doc="The rope out")

    async def on_start(self) -> None:
        self.greased = 0
        self.out = 0.0
        self.Rope.publish(Rope())

    # -- the author's own helpers, named as the engine's private methods once were --------------

    def _validate(self, length: float) -> None:
        if length > 10.0:
            raise TOO_LONG(limit=10.0)

    async def _run(self, length: float) -> None:
        while self.out < length:
            await self.clock.sleep(1.0)
            self.out += 1.0
            self.Rope.publish(Rope(self.out))

    def _settle(self) -> float:
        return round(self.out, 3)

    def service(self) -> None:
        self.greased += 1

    # -- its services ------------------------------------------------------------------------

    @activity(interrupts=("Reel",), throws=(TOO_LONG,), validate=_check_length)
    async def Reel(self, length: Annotated[Double, "Metres of rope out"] = 1.0
                   ) -> Annotated[Double, Out("out", "Metres out")]:
        """Reel rope out until *length* metres are out."""
        await self._run(length)
        return self._settle()

    @function
    def Grease(self) -> None:
        """Grease the drum."""
        self.service()


@pytest.fixture
async def winch() -> AsyncIterator[Winch]:
    async with ComponentHost(clock=ManualClock(), factories={"winch": Winch}, function_grace=0.01) as host:
        loaded = await host.load("winch")
        assert isinstance(loaded, Winch)
        yield loaded


async def _advance(winch: Winch, until: Request) -> None:
    """Step the manual clock one second at a time until *until* ended."""
    clock = winch.clock
    assert isinstance(clock, ManualClock)
    while until.running:
        await clock.advance(1.0)


async def test_an_authors_helpers_are_never_taken_for_the_engines(winch: Winch) -> None:
    engine = winch.engine
    assert isinstance(engine, RequestEngine) and engine.component is winch
    greased = await engine.send("Grease")
    assert (greased.status, winch.greased) == ("done", 1)
    reel = await engine.send("Reel", {"length": 3.0})
    assert reel.running and engine.requests.running() == [reel]
    await _advance(winch, reel)
    assert (reel.status, reel.output) == ("done", {"out": 3.0})
    assert winch.Rope.read() == Rope(3.0)


async def test_the_engine_interrupts_and_refuses_as_the_component_declares(winch: Winch) -> None:
    engine = winch.engine
    first = await engine.send("Reel", {"length": 8.0})
    second = await engine.send("Reel", {"length": 5.0})  # interrupts the first: its stop path ran before
    assert first.exception == {"ex": "::genom::interrupted", "detail": {"by": "Reel"}}
    refused = await engine.send("Reel", {"length": 20.0})
    assert refused.exception == {"ex": "::winch::TOO_LONG", "detail": {"limit": 10.0}}
    assert second.running
    await engine.interrupt_all(by="test")
    assert second.exception == {"ex": "::genom::interrupted", "detail": {"by": "test"}}


async def test_kill_through_the_engine_unloads_and_refuses_later_sends(winch: Winch) -> None:
    unloaded = asyncio.Event()
    winch.host.add_unload_listener(lambda name: unloaded.set())
    reeling = await winch.engine.send("Reel", {"length": 9.0})
    await winch.engine.send("kill")
    await unloaded.wait()
    assert reeling.exception == {"ex": "::genom::interrupted", "detail": {"by": "kill"}}
    assert winch.engine.killed and "winch" not in winch.host.instances
    with pytest.raises(GenomException) as refused:
        await winch.send("Grease")
    assert winch.engine.exception_object(refused.value) == {"ex": "::genom::disallowed"}
