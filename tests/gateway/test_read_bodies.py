"""Whole reads of the audio window share one body per publication and form, made ahead for polled forms."""

from __future__ import annotations

import asyncio
import gc
import weakref
from collections.abc import AsyncIterator
from typing import Any

import pytest

from aiogenomix.components.capture import PortView
from aiogenomix.components.core import ComponentHost, ScaledClock
from aiogenomix.components.kemarcapture import KemarPortData
from aiogenomix.gateway._pieces import PiecesPayload
from aiogenomix.gateway._read_bodies import IDLE_PUBLICATIONS, ReadBodies
from aiogenomix.gateway._routes_ports import read_body
from aiogenomix.gateway._unloads import Unloads
from tests.gateway.test_port_pieces import Windowed, window


class Maker:
    """Makes bodies (the value's index, as bytes), counting them; *made* is set at each."""

    def __init__(self) -> None:
        self.values: list[Any] = []
        self.made = asyncio.Event()

    def __call__(self, port: Any, value: Any) -> bytes:
        self.values.append(value)
        self.made.set()
        return b"%d" % value.data.index


@pytest.fixture
async def host() -> AsyncIterator[ComponentHost]:
    async with ComponentHost(clock=ScaledClock(1), factories={"windowed": Windowed}) as running:
        yield running


@pytest.fixture
async def parts(host: ComponentHost) -> AsyncIterator[tuple[Windowed, ReadBodies, asyncio.Future[None]]]:
    component = await host.load("windowed")
    assert isinstance(component, Windowed)
    unloads = Unloads(host)
    host.add_unload_listener(unloads.notice)
    stopping: asyncio.Future[None] = asyncio.get_running_loop().create_future()
    yield component, ReadBodies(unloads, lambda: stopping), stopping
    if not stopping.done():
        stopping.set_result(None)


def publish(component: Windowed, chunks: int) -> PortView:
    view = PortView(window(12, 50, chunks, seed=chunks), 44100, 0.0, KemarPortData)
    component.Port.publish(view)
    return view


def read(bodies: ReadBodies, component: Windowed, make: Maker, binary: bool = False) -> bytes:
    body = bodies.body(component.Port, component.Port.read(), (binary, None), make)
    assert isinstance(body, bytes)
    return body


async def test_every_read_of_a_publication_and_form_shares_one_body(
        parts: tuple[Windowed, ReadBodies, asyncio.Future[None]]) -> None:
    component, bodies, _ = parts
    publish(component, 3)
    json_maker, binary_maker = Maker(), Maker()
    assert [read(bodies, component, json_maker) for _ in range(3)] == [b"3"] * 3
    assert read(bodies, component, binary_maker, binary=True) == b"3"
    assert len(json_maker.values) == len(binary_maker.values) == 1


async def test_a_form_read_during_a_publication_is_made_when_the_next_is_published(
        parts: tuple[Windowed, ReadBodies, asyncio.Future[None]]) -> None:
    component, bodies, _ = parts
    publish(component, 3)
    polled, other = Maker(), Maker()
    read(bodies, component, polled)
    read(bodies, component, other, binary=True)
    polled.made.clear()
    other.made.clear()
    publish(component, 4)
    await polled.made.wait()  # made ahead, before anyone reads it
    assert [v.data.index for v in polled.values] == [3, 4]
    assert read(bodies, component, polled) == b"4"
    assert len(polled.values) == 2  # the read found it made
    # Both forms were read during publication 3, so both were made for 4; during 4 only JSON was.
    publish(component, 5)
    polled.made.clear()
    await polled.made.wait()
    assert [v.data.index for v in other.values] == [3, 4]


async def test_the_task_of_a_port_ends_with_its_instance_or_when_nobody_reads(
        host: ComponentHost, parts: tuple[Windowed, ReadBodies, asyncio.Future[None]]) -> None:
    component, bodies, _ = parts
    publish(component, 3)
    read(bodies, component, Maker())
    task = bodies._ports[component.Port].task
    assert task is not None
    # Publications nobody reads, a loop turn apart as a capture's: the task ends after a bounded number.
    for chunks in range(4, 4 + 10 * IDLE_PUBLICATIONS):
        publish(component, chunks)
        await asyncio.sleep(0)
        if task.done():
            break
    assert task.done() and IDLE_PUBLICATIONS < chunks - 3
    read(bodies, component, Maker())  # a new reader starts a new task
    task = bodies._ports[component.Port].task
    assert task is not None and not task.done()
    await host.unload("windowed")
    await asyncio.wait_for(task, 5)


async def test_a_port_nobody_reads_any_more_lets_go_of_its_bodies(
        parts: tuple[Windowed, ReadBodies, asyncio.Future[None]]) -> None:
    # A JSON body of the audio window holds its publication's chunks and their texts (150 MB for
    # a 59 MiB window): kept after nobody reads, it would outlive the port's moving on.
    component, bodies, _ = parts
    publish(component, 3)

    made: list[weakref.ref[PiecesPayload]] = []

    def make(port: Any, value: Any) -> PiecesPayload:
        body = PiecesPayload([b"%d" % value.data.index], "application/json")
        made.append(weakref.ref(body))
        return body

    body = bodies.body(component.Port, component.Port.read(), (False, None), make)
    assert bodies.body(component.Port, component.Port.read(), (False, None), make) is body  # kept while read
    task = bodies._ports[component.Port].task
    assert task is not None
    del body
    for chunks in range(4, 4 + 10 * IDLE_PUBLICATIONS):  # publications nobody reads, a loop turn apart
        publish(component, chunks)
        await asyncio.sleep(0)
        if task.done():
            break
    assert task.done()
    gc.collect()
    assert len(made) >= 2 and not [ref for ref in made if ref() is not None]  # nor those made ahead
    again = bodies.body(component.Port, component.Port.read(), (False, None), make)
    assert again.decode() == str(chunks)  # the next read makes the body of the port as it is now


async def test_the_tasks_end_when_the_gateway_stops(parts: tuple[Windowed, ReadBodies, asyncio.Future[None]]) -> None:
    component, bodies, stopping = parts
    publish(component, 3)
    read(bodies, component, Maker())
    task = bodies._ports[component.Port].task
    assert task is not None
    stopping.set_result(None)
    await asyncio.wait_for(task, 5)


async def test_the_bodies_of_an_unloaded_instance_go_with_it() -> None:
    async with ComponentHost(clock=ScaledClock(1), factories={"windowed": Windowed}) as host:
        component = await host.load("windowed")
        assert isinstance(component, Windowed)
        unloads = Unloads(host)
        host.add_unload_listener(unloads.notice)
        stopping: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        bodies = ReadBodies(unloads, lambda: stopping)
        publish(component, 3)
        # As the read route makes its bodies.
        read_body(bodies, "Port", component.Port, component.Port.read(), None, None, False)
        task = bodies._ports[component.Port].task
        assert task is not None
        await host.unload("windowed")
        await asyncio.wait_for(task, 5)
        del component, task
        gc.collect()
        assert len(bodies._ports) == 0  # nothing kept the port alive


async def test_a_body_that_cannot_be_made_is_left_to_the_read(
        parts: tuple[Windowed, ReadBodies, asyncio.Future[None]]) -> None:
    component, bodies, _ = parts
    publish(component, 3)
    working = Maker()

    def fails(port: Any, value: Any) -> bytes:
        raise ValueError("cannot")

    read(bodies, component, working)
    with pytest.raises(ValueError, match="cannot"):  # the read meets the failure itself
        bodies.body(component.Port, component.Port.read(), (True, None), fails)
    working.made.clear()
    publish(component, 4)
    await working.made.wait()  # the form that works is made ahead; the failed one is passed over
    task = bodies._ports[component.Port].task
    assert task is not None and not task.done()
    assert read(bodies, component, working) == b"4"
    assert len(working.values) == 2
