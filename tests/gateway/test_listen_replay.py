"""Issue 29, item 7: a storm of listens replaying a session's latest events holds no copies of them.

3,000 listens with ``Last-Event-ID: 0`` that dropped 50 ms into a 1,000-event replay raised the
gateway's memory by 343 MiB, and it did not come back: tracemalloc showed each listen holding the
whole replay joined into one write, and its own id-prefixed copy of every event.  Now the events
are framed once per form, the frames shared, and a replay goes out in slices (``bench/storm.py``
measures the storm; docs/benchmarks.md).
"""

from __future__ import annotations

import asyncio
import gc
import re
import tracemalloc

import aiohttp

from aiogenomix.components.core import RequestEvent
from aiogenomix.components.core.runtime import RequestStatus
from aiogenomix.gateway._sessions import WRITE_SLICE, Session
from aiogenomix.gateway._sse import STANDARD_FORM

EVENTS = 1000


class Done(RequestStatus):
    """A request of demo that ended with a padded output."""

    def __init__(self, number: int) -> None:
        self.number, self.instance, self.session, self.oneway, self.serial, self.sent = number, "demo", "storm", \
            False, number, 0.0
        self.status, self.output, self.exception = "done", {"pad": "x" * 250}, None


def test_listens_replaying_the_latest_events_share_them() -> None:
    session = Session("storm", backlog=EVENTS)
    for n in range(EVENTS):
        session.deliver(RequestEvent(Done(n), 0.0))
    # Framed once in the standard form (by the first listen that takes them), then shared.
    backlog = sum(len(logged.framed(STANDARD_FORM)) for logged in session.recent)
    gc.collect()
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        listeners = [session.attach(form=STANDARD_FORM, last_id="0") for _ in range(200)]
        held = tracemalloc.get_traced_memory()[0] - before
        # A pointer an event each (and the deques'), not the events again: 200 listens of a 300 kB backlog
        # held 60 MB before.
        assert held < 200 * EVENTS * 16 and held < backlog * 10, (held, backlog)
        # What one write takes: a slice, not the whole replay joined.
        first = listeners[0].take()
        assert WRITE_SLICE - 400 < len(first) <= WRITE_SLICE and first.startswith(b"id: 1\nevent: request\n")
        assert first.split(b"\n\n")[0] == b'id: 1\nevent: request\ndata: {"id":"demo::0","status":"done",' \
            b'"output":{"pad":"' + b"x" * 250 + b'"}}'
        # Every listen's slices are the same frames: taking them all makes no copy of the events.
        before = tracemalloc.get_traced_memory()[0]
        for listener in listeners[1:]:
            assert listener.take() == first
        assert tracemalloc.get_traced_memory()[0] - before < 200 * 1000
    finally:
        tracemalloc.stop()


async def test_a_replay_of_a_thousand_events_arrives_whole_in_slices(gateway: str, http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo")
    async with aiohttp.ClientSession(base_url=gateway, connector=aiohttp.TCPConnector(limit=16)) as many:
        async def send() -> None:
            async with many.get("/module/demo/send/GetSpeed", params={"s": "replay"}) as reply:
                assert reply.status == 200
        await asyncio.gather(*(send() for _ in range(EVENTS)))
    host, port = gateway.removeprefix("http://").rstrip("/").split(":")
    reader, writer = await asyncio.open_connection(host, int(port))
    try:
        writer.write(b"GET /session/listen?s=replay HTTP/1.1\r\nHost: 127.0.0.1\r\nAccept: text/event-stream\r\n"
                     b"Last-Event-ID: 0\r\n\r\n")
        received = b""
        while received.count(b"event: request") < EVENTS:
            received += await asyncio.wait_for(reader.read(65536), 30)
        ids = [int(n) for n in re.findall(rb"\nid: (\d+)\nevent: request\n", b"\n" + received)]
        assert ids == list(range(1, EVENTS + 1))  # every one, in order, none twice
    finally:
        writer.close()
