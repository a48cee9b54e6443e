"""The gateway's copies of remote requests stay right whatever order the host's news arrives in (sans I/O).

The host answers a query before it publishes the events of the same loop turn, and it reuses a
request's number once it is cleaned, so a late event may be about a request the gateway has
already cleaned.  These tests feed the proxy the orders seen on a loaded machine.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from typing import Any

import orjson
import pytest

from aiogenomix.components.core import ComponentHost
from aiogenomix.components.core.runtime import RemoteUnreachable
from aiogenomix.remote import _proxy
from aiogenomix.remote._proxy import RemoteInstance, RemoteLink, RemoteTimeouts
from aiogenomix.remote._wire import OfferKey

_DESCRIPTION = {"component": "demo", "version": "1.0", "services": [], "ports": []}


class _Publisher:
    def __init__(self) -> None:
        self.sent: list[bytes] = []
        self.published = asyncio.Event()

    def put(self, body: bytes) -> None:
        self.sent.append(body)
        self.published.set()


class _Rig:
    """A proxy whose queries get scripted replies and whose events the test delivers."""

    def __init__(self, proxy: RemoteInstance, announced: list[dict[str, Any]]) -> None:
        self.proxy = proxy
        self.announced = announced
        self.replies: list[dict[str, Any]] = []
        self.asked: list[tuple[str, dict[str, Any]]] = []

    def event(self, number: int, serial: int, status: str, **rest: Any) -> None:
        body = {"id": f"demo::{number}", "status": status, "serial": serial, **rest}
        self.proxy._take_event(orjson.dumps({"status": body, "session": "s"}))


@pytest.fixture
async def rig(monkeypatch: pytest.MonkeyPatch) -> AsyncIterator[_Rig]:
    announced: list[dict[str, Any]] = []
    async with ComponentHost(factories={}) as host:
        host.add_request_listener(lambda request: announced.append(request.status_object()))
        link = RemoteLink(None, "gateway1", RemoteTimeouts(), lambda zid: 0.0)  # type: ignore[arg-type]
        offer = OfferKey(2, "robot1", "zid1", "demo", "aiogenomix/offer/2/robot1/zid1/demo")
        proxy = RemoteInstance(host, link, offer, "demo", _DESCRIPTION, dict)
        proxy._cleans = _Publisher()
        test_rig = _Rig(proxy, announced)

        async def ask(session: Any, key: str, payload: Any, timeout: float, **_: Any) -> dict[str, Any]:
            test_rig.asked.append((key.rsplit("/", 1)[-1], dict(payload)))
            return test_rig.replies.pop(0)

        monkeypatch.setattr(_proxy, "ask", ask)
        yield test_rig


async def test_a_late_event_of_a_cleaned_request_does_not_bring_it_back(rig: _Rig) -> None:
    refused = {"id": "demo::0", "status": "error", "serial": 0, "exception": {"ex": "::demo::TOO_FAR_AWAY"}}
    rig.replies.append(refused)
    request = await rig.proxy.send("GotoPosition", {"posRef": 2}, session="s")
    assert request.status == "error"
    await rig.proxy.clean("demo::0")
    rig.event(0, 0, "error", exception={"ex": "::demo::TOO_FAR_AWAY"})  # published after the reply
    assert 0 not in rig.proxy._remote
    assert rig.announced == [{"id": "demo::0", "status": "error", "exception": {"ex": "::demo::TOO_FAR_AWAY"}}]


async def test_the_next_request_under_a_reused_number_is_not_ended_by_its_predecessor(rig: _Rig) -> None:
    rig.replies.append({"id": "demo::0", "status": "error", "serial": 0, "exception": {"ex": "::demo::TOO_FAR_AWAY"}})
    await rig.proxy.send("GotoPosition", {"posRef": 2}, session="s")
    await rig.proxy.clean("demo::0")
    # The host reuses number 0; its reply overtakes the predecessor's late events.
    rig.replies.append({"id": "demo::0", "status": "sent", "serial": 1})
    move = await rig.proxy.send("MoveDistance", {"distRef": 1}, session="s")
    rig.event(0, 0, "error", exception={"ex": "::demo::TOO_FAR_AWAY"})
    rig.event(0, 1, "sent")
    assert move.running
    rig.event(0, 1, "done", output={})
    assert move.status == "done"
    assert [status["status"] for status in rig.announced] == ["error", "sent", "done"]


async def test_a_reply_that_ends_the_request_is_not_undone_by_its_late_sent_event(rig: _Rig) -> None:
    rig.replies.append({"id": "demo::0", "status": "done", "serial": 0, "output": {}})
    request = await rig.proxy.send("SetSpeed", {"speedRef": 1}, session="s")
    rig.event(0, 0, "sent")
    rig.event(0, 0, "done", output={})
    assert request.status == "done" and rig.proxy._remote[0] is request
    assert rig.announced == [{"id": "demo::0", "status": "done", "output": {}}]


async def test_a_request_cleaned_by_another_gateway_gives_way_to_the_next_under_its_number(rig: _Rig) -> None:
    rig.replies.append({"id": "demo::0", "status": "done", "serial": 0, "output": {}})
    first = await rig.proxy.send("SetSpeed", {"speedRef": 1}, session="s")
    rig.event(0, 3, "sent")  # another client cleaned demo::0 on the host and sent a new request
    assert first.status == "done"
    assert rig.proxy._remote[0].running and rig.proxy._remote[0] is not first


async def test_a_clean_answered_by_the_gateway_reaches_the_host_with_its_next_query(rig: _Rig) -> None:
    rig.replies.append({"id": "demo::0", "status": "done", "serial": 0, "output": {}})
    await rig.proxy.send("SetSpeed", {"speedRef": 1}, session="s")
    await rig.proxy.clean("demo::0")  # answered here: the host is not asked
    rig.replies.append({"id": "demo::0", "status": "done", "serial": 1, "output": {}})
    await rig.proxy.send("SetSpeed", {"speedRef": 1}, session="s")
    # The host cleans demo::0 before it takes the send, so it gives the number out again, as genomix does.
    assert [(operation, payload.get("cleaned")) for operation, payload in rig.asked] == [
        ("send", None), ("send", ["0"])]
    assert rig.proxy._cleans.sent == []  # type: ignore[attr-defined]


async def test_a_clean_no_query_carries_is_published(rig: _Rig) -> None:
    rig.proxy._started = True
    rig.replies.append({"id": "demo::0", "status": "done", "serial": 0, "output": {}})
    await rig.proxy.send("SetSpeed", {"speedRef": 1}, session="s")
    await rig.proxy.clean("demo::0")
    published = rig.proxy._cleans.published  # type: ignore[attr-defined]
    await published.wait()
    assert [orjson.loads(body) for body in rig.proxy._cleans.sent] == [{"ids": ["0"]}]  # type: ignore[attr-defined]


class _SilentSession:
    """A Zenoh session whose queries get no reply (the host is frozen, or about to be found gone)."""

    def __init__(self) -> None:
        #: Set once a query was asked.
        self.asked = asyncio.Event()

    def get(self, *args: Any, **kwargs: Any) -> None:
        self.asked.set()


async def test_a_host_found_gone_ends_the_queries_waiting_for_it_at_once() -> None:
    async with ComponentHost(factories={}) as host:
        session = _SilentSession()
        link = RemoteLink(session, "gateway1", RemoteTimeouts(send=60.0), lambda zid: 0.0)  # type: ignore[arg-type]
        offer = OfferKey(2, "robot1", "zid1", "demo", "aiogenomix/offer/2/robot1/zid1/demo")
        proxy = RemoteInstance(host, link, offer, "demo", _DESCRIPTION, dict)
        sending = asyncio.ensure_future(proxy.send("GotoPosition", {"posRef": 0.5}))
        await session.asked.wait()  # the send's query is asked, and waits for a reply
        assert len(proxy._pending) == 1
        proxy.lost("demo ran on component host robot1, which stopped or cannot be reached")
        with pytest.raises(RemoteUnreachable) as gone:
            await sending  # at once, not after the send's 60 s
        assert ("send GotoPosition of demo: its host robot1 went away, or withdrew demo, before answering (last "
                "heard 0.00 s ago, at ") in str(gone.value)
