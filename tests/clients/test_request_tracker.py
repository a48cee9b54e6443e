"""The request tracker against a fake gateway: early events, duplicates, quarantine after a reconnect, cleaning."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest
from aiogenomix.clients import ModuleUnloaded
from aiogenomix.clients._module import ModuleDescription
from aiogenomix.clients._request import AsyncRequest
from aiogenomix.clients._tracker import RequestTracker

INFO: dict[str, Any] = {
    "name": "demo", "component": "demo", "services": [
        {"name": "Go", "kind": "activity", "doc": "", "task": None, "parameters": [], "interrupts": [], "throws": []},
    ], "ports": [], "exceptions": [], "tasks": [],
}
SENT = {"id": "demo::0", "status": "sent"}
DONE = {"id": "demo::0", "status": "done", "output": {}}


class FakeGateway:
    """Records cleans and answers status re-reads from a table."""

    def __init__(self) -> None:
        self.cleaned: list[str] = []
        self.statuses: dict[str, dict[str, Any]] = {}

    async def status(self, module: str, request_id: str) -> dict[str, Any]:
        return self.statuses[request_id]

    async def clean(self, module: str, request_id: str) -> None:
        self.cleaned.append(request_id)


async def _abort(handle: AsyncRequest, timeout: float | None) -> None:
    raise AssertionError("not used")


def make(tracker: RequestTracker, rid: str = "demo::0", epoch: int | None = None) -> tuple[AsyncRequest, list[Any]]:
    spec = ModuleDescription(INFO).services["Go"]  # type: ignore[arg-type]
    ends: list[AsyncRequest] = []
    handle = AsyncRequest(rid, "demo", spec, abort=_abort, epoch=tracker.epoch if epoch is None else epoch)
    handle.add_done_callback(ends.append)
    return handle, ends


@pytest.fixture
def setup() -> tuple[RequestTracker, FakeGateway, list[dict[str, Any]]]:
    gateway = FakeGateway()
    reports: list[dict[str, Any]] = []
    tracker = RequestTracker(gateway, reports.append)  # type: ignore[arg-type]
    tracker.on_attached()
    return tracker, gateway, reports


async def settle(tracker: RequestTracker) -> None:
    await asyncio.gather(*tracker._tasks)


async def test_event_before_the_send_reply(setup: Any) -> None:
    tracker, gateway, _ = setup
    tracker.on_request_event(DONE)                 # the stream was faster than the send reply
    handle, ends = make(tracker)
    tracker.register(handle, SENT)
    assert handle.status == "done" and ends == [handle]
    await settle(tracker)
    assert gateway.cleaned == ["demo::0"] and len(tracker) == 0


async def test_reply_end_waits_for_the_final_event_before_cleaning(setup: Any) -> None:
    tracker, gateway, _ = setup
    handle, ends = make(tracker)
    tracker.register(handle, DONE)                 # a quick function: done in its reply
    assert ends == [handle]
    await settle(tracker)
    assert gateway.cleaned == [] and len(tracker) == 1
    tracker.on_request_event(DONE)                 # now the id cannot receive a stale event
    tracker.on_request_event(DONE)                 # a duplicate changes nothing
    await settle(tracker)
    assert gateway.cleaned == ["demo::0"] and ends == [handle]


async def test_reconnect_rereads_and_quarantines_until_the_backlog_is_read(setup: Any) -> None:
    tracker, gateway, _ = setup
    handle, ends = make(tracker)
    tracker.register(handle, SENT)
    gateway.statuses["demo::0"] = DONE
    tracker.on_attached()                          # reconnected: demo::0 may have ended unseen
    await settle(tracker)
    assert ends == [handle] and gateway.cleaned == []
    later, _ = make(tracker, "demo::1")            # sent after the reconnect
    tracker.register(later, {"id": "demo::1", "status": "sent"})
    tracker.on_request_event({"id": "demo::1", "status": "done", "output": {}})
    await settle(tracker)
    assert sorted(gateway.cleaned) == ["demo::0", "demo::1"] and len(tracker) == 0


async def test_late_event_of_a_quarantined_request_is_not_reported_twice(setup: Any) -> None:
    tracker, gateway, _ = setup
    handle, ends = make(tracker)
    tracker.register(handle, SENT)
    gateway.statuses["demo::0"] = DONE
    tracker.on_attached()
    await settle(tracker)
    tracker.on_request_event(DONE)                 # it was in the backlog after all
    await settle(tracker)
    assert ends == [handle] and gateway.cleaned == ["demo::0"]


async def test_ping_releases_the_quarantine(setup: Any) -> None:
    tracker, gateway, _ = setup
    handle, _ = make(tracker)
    tracker.register(handle, DONE)
    tracker.on_attached()                          # its final event may be lost
    tracker.on_ping()
    await settle(tracker)
    assert gateway.cleaned == ["demo::0"]


async def test_send_in_flight_across_a_reconnect_is_reread(setup: Any) -> None:
    tracker, gateway, _ = setup
    handle, ends = make(tracker, epoch=tracker.epoch)
    tracker.on_attached()                          # the stream dropped and came back during the send
    gateway.statuses["demo::0"] = DONE
    tracker.register(handle, SENT)
    await settle(tracker)
    assert ends == [handle] and handle.status == "done"


async def test_unload_fails_what_is_left(setup: Any) -> None:
    tracker, gateway, _ = setup
    handle, ends = make(tracker)
    tracker.register(handle, SENT)
    tracker.on_unload("demo")
    assert isinstance(handle.exception, ModuleUnloaded) and ends == [handle] and len(tracker) == 0
