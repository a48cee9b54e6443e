"""The request tracker: matches ``request`` events to handles, re-reads status after a reconnect, cleans.

Why cleaning waits for the final event: the gateway reuses the number of a
cleaned request, and the final ``request`` event of a request may still be on
its way when the handle already knows the end (from the ``send`` reply of a
quick function, or from a status re-read).  Cleaning then would let a new
request take the number and receive the old event.  So a handle is cleaned
once its final event has been read.

When the stream drops, an event the gateway had queued for the dead
connection is lost for good, while events that occurred with no listener come
later in the new stream's backlog.  After a reconnect the tracker re-reads the
status of every pending request; ended ones whose final event was not seen are
*quarantined* (kept, not cleaned) until the stream proves its backlog was
read: their own late event, an event of a request sent after the reconnect,
or a ``: ping``.  Each handle reports its end exactly once whatever the order.
"""

from __future__ import annotations

import asyncio
from collections import OrderedDict
from collections.abc import Callable, Coroutine
from typing import Any

from ._errors import (
    ClientClosed,
    GenomixError,
    ModuleUnloaded,
    NotFound,
    TransportError,
)
from ._http import HttpGateway
from ._request import AsyncRequest
from ._wire import StatusObject

__all__ = ["RequestTracker"]

#: Events for ids not (yet) known; they belong to sends whose reply is still on its way.
_EARLY_LIMIT = 1000


class RequestTracker:
    """Every request a client has sent and not yet cleaned, keyed by id.

    Args:
        gateway: Where status re-reads and cleans go.
        report: Called with an asyncio exception-handler context for failures nobody awaits.
    """

    def __init__(self, gateway: HttpGateway, report: Callable[[dict[str, Any]], None]) -> None:
        self._gateway = gateway
        self._report = report
        self._handles: dict[str, AsyncRequest] = {}
        self._early: OrderedDict[str, list[StatusObject]] = OrderedDict()
        self._quarantined: set[str] = set()
        self._tasks: set[asyncio.Task[None]] = set()
        #: Incremented each time a listen stream is attached (headers received).
        self.epoch = 0

    def __len__(self) -> int:
        return len(self._handles)

    def pending(self) -> list[AsyncRequest]:
        """The tracked requests that have not ended, oldest first."""
        return [h for h in self._handles.values() if not h.done]

    # -- from the client -----------------------------------------------------------------------

    def register(self, handle: AsyncRequest, reply: StatusObject) -> None:
        """Track a request from its ``send`` reply (events may have come first)."""
        self._handles[handle.id] = handle
        for status in self._early.pop(handle.id, []):
            self._take(handle, status, from_event=True)
        handle.apply(reply)
        if handle.epoch != self.epoch:
            # The stream reconnected while this send was in flight: its events may be lost.
            self._spawn(self._reread(handle), f"reread {handle.id}")
        self._settle(handle)

    def on_reply(self, handle: AsyncRequest, status: StatusObject) -> None:
        """A status read by request (abort, status): it may end the handle, but is not its final event."""
        self._take(handle, status, from_event=False)

    # -- from the event stream -----------------------------------------------------------------

    def on_request_event(self, status: StatusObject) -> None:
        """A ``request`` event."""
        handle = self._handles.get(status["id"])
        if handle is None:
            early = self._early.setdefault(status["id"], [])
            early.append(status)
            while len(self._early) > _EARLY_LIMIT:
                self._early.popitem(last=False)
            return
        if handle.epoch == self.epoch and self._quarantined:
            # Sent after the stream attached, so the backlog before it has been read.
            self._release_quarantine()
        self._take(handle, status, from_event=True)

    def on_ping(self) -> None:
        """A ``: ping`` comment: the gateway had nothing queued, so no backlog remains."""
        self._release_quarantine()

    def on_attached(self) -> None:
        """A listen stream (re)attached: re-read what may have ended while events were lost."""
        self.epoch += 1
        if self.epoch == 1:
            return  # the first stream: nothing was sent before it
        for handle in list(self._handles.values()):
            if not handle.done:
                self._spawn(self._reread(handle), f"reread {handle.id}")
            elif not handle.final_event_seen:
                self._quarantined.add(handle.id)

    def on_unload(self, module: str) -> None:
        """An ``unload`` event: the instance and its requests are gone."""
        for handle in [h for h in self._handles.values() if h.module == module]:
            handle.fail(ModuleUnloaded(f"{module} was unloaded before {handle.service} ({handle.id}) ended"))
            del self._handles[handle.id]
            self._quarantined.discard(handle.id)
        for rid in [rid for rid in self._early if rid.rpartition("::")[0].lstrip(":") == module]:
            del self._early[rid]

    def fail_pending(self, error: GenomixError) -> None:
        """End every pending request locally (the stream is lost for good, or the session stopped)."""
        for handle in self.pending():
            handle.fail(error)

    # -- internals ------------------------------------------------------------------------------

    def _take(self, handle: AsyncRequest, status: StatusObject, from_event: bool) -> None:
        handle.apply(status)
        if from_event and status["status"] != "sent":
            handle.final_event_seen = True
        self._settle(handle)

    def _settle(self, handle: AsyncRequest) -> None:
        """Clean a handle once it has ended and its final event can no longer arrive."""
        if not (handle.done and handle.final_event_seen):
            return
        self._quarantined.discard(handle.id)
        if self._handles.get(handle.id) is handle:
            del self._handles[handle.id]
            self._spawn(self._clean(handle), f"clean {handle.id}")

    def _release_quarantine(self) -> None:
        released, self._quarantined = self._quarantined, set()
        for rid in released:
            handle = self._handles.get(rid)
            if handle is not None:
                handle.final_event_seen = True  # its event was lost with the dropped connection
                self._settle(handle)

    async def _reread(self, handle: AsyncRequest) -> None:
        try:
            status = await self._gateway.status(handle.module, handle.id)
        except NotFound as exc:
            # The gateway forgot it (module unloaded or reloaded): no end will ever be reported.
            handle.fail(exc)
            self._handles.pop(handle.id, None)
            return
        except TransportError:
            return  # the stream is down again; the next reconnect re-reads it
        handle.apply(status)
        if handle.done and not handle.final_event_seen:
            self._quarantined.add(handle.id)

    async def _clean(self, handle: AsyncRequest) -> None:
        try:
            await self._gateway.clean(handle.module, handle.id)
        except (NotFound, TransportError, ClientClosed):
            pass  # already forgotten, or unreachable: the gateway drops old ended requests itself

    def _spawn(self, coro: Coroutine[Any, Any, None], name: str) -> None:
        task = asyncio.get_running_loop().create_task(coro, name=f"aiogenomix {name}")
        self._tasks.add(task)
        task.add_done_callback(self._task_done)

    def _task_done(self, task: asyncio.Task[None]) -> None:
        self._tasks.discard(task)
        if not task.cancelled() and task.exception() is not None:
            self._report({"message": f"{task.get_name()} failed", "exception": task.exception(), "task": task})

    async def close(self, error: GenomixError) -> None:
        """Fail pending handles with *error*, clean ended ones, and finish background work."""
        ended = [h for h in self._handles.values() if h.done]
        self.fail_pending(error)
        self._handles.clear()
        self._quarantined.clear()
        self._early.clear()
        # The session is about to stop, so no id can be reused by us: clean everything ended.
        await asyncio.gather(*(self._clean(h) for h in ended))
        if self._tasks:
            await asyncio.gather(*list(self._tasks), return_exceptions=True)
