"""Event streams other than the client's own session: a port's publications (``watch``), any session's events.

Both are read in the standard form (``Accept: text/event-stream``): events carry ids, and a
stream that drops is opened again with the last id, so a watch of numbered data (the audio
window) resumes after the chunks it had, as ``since=`` would, and loses nothing the port
still holds.
"""

from __future__ import annotations

import asyncio
import dataclasses
from collections.abc import AsyncIterator, Mapping
from typing import Any

import aiohttp
import orjson

from ._errors import ModuleUnloaded, ProtocolError, TransportError
from ._http import HttpGateway
from ._sse import ServerSentEvent, SSEParser

__all__ = ["PortEvent", "SessionEvent", "watch_port", "session_events"]

#: Reconnections tried after a stream drops, with the delay before each.
_RETRIES = (0.0, 0.05, 0.2, 0.5, 1.0, 2.0)


@dataclasses.dataclass(frozen=True)
class PortEvent:
    """One publication of a watched port.

    Attributes:
        data: The port's data as genomix JSON (decoded: arrays are lists).  For numbered data
            (the audio window) it holds only the items the reader had not had yet.
        lost: Items the window no longer held (numbered data), or publications skipped while
            the reader was busy (other data).
        id: The newest item it holds (numbered data) or the publication's number.
    """

    data: Any
    lost: int
    id: str | None


@dataclasses.dataclass(frozen=True)
class SessionEvent:
    """One event of a session: ``request`` (a status object), ``unload`` (an instance) or ``quit`` (the session)."""

    event: str
    data: Any


async def _events(gateway: HttpGateway, path: str, params: Mapping[str, str], last_id: str | None,
                  idle_timeout: float) -> AsyncIterator[ServerSentEvent]:
    """The events of one connection to *path* (none when the gateway answers 204: the stream has ended)."""
    headers = {"Accept": "text/event-stream"}
    if last_id is not None:
        headers["Last-Event-ID"] = last_id
    timeout = aiohttp.ClientTimeout(total=None, sock_connect=10.0, sock_read=idle_timeout)
    async with gateway.http.get(gateway.base + path, params=dict(params), headers=headers, timeout=timeout) as reply:
        if reply.status == 204:
            return
        if reply.status != 200:
            raise gateway.error_for(reply.status, await reply.read(), path)
        parser = SSEParser()
        while chunk := await reply.content.readany():
            for item in parser.feed(chunk):
                if isinstance(item, ServerSentEvent):
                    yield item


async def _resuming(gateway: HttpGateway, path: str, params: Mapping[str, str], idle_timeout: float, *,
                    resume_param: str | None = None) -> AsyncIterator[ServerSentEvent]:
    """The events of *path* (queried with *params*), the stream opened again with its last id when it drops.

    A watch's ``since``, named by *resume_param*, is replaced by the last id when the stream is
    opened again: the first one would start again from the same item.
    """
    last_id: str | None = None
    failures = 0
    while True:
        query = dict(params)
        if last_id is not None and resume_param is not None and resume_param in query:
            query[resume_param] = last_id
        try:
            async for event in _events(gateway, path, query, last_id, idle_timeout):
                failures = 0
                last_id = event.id if event.id is not None else last_id
                yield event
            return
        except (aiohttp.ClientError, OSError, TimeoutError) as exc:
            if failures >= len(_RETRIES):
                raise TransportError(f"the stream {path} of {gateway.base} dropped and could not be opened "
                                     f"again: {exc or type(exc).__name__}") from exc
            await asyncio.sleep(_RETRIES[failures])
            failures += 1


async def watch_port(gateway: HttpGateway, instance: str, port: str, *, since: int | None = None,
                     element: str | None = None, idle_timeout: float = 60.0) -> AsyncIterator[PortEvent]:
    """The publications of ``instance/port`` as they come (see :meth:`AsyncClient.watch`)."""
    params = {"s": gateway.session_name} if gateway.session_name else {}
    if since is not None:
        params["since"] = str(int(since))
    if element is not None:
        params["name"] = element
    path = f"/module/{instance}/watch/{port}"
    # A watch of numbered data that drops resumes after the newest item it had (its last id), not
    # again after the item it first asked for.
    async for event in _resuming(gateway, path, params, idle_timeout, resume_param="since"):
        if event.event == "unload":
            raise ModuleUnloaded(f"{instance} was unloaded: its port {port} is no longer published")
        if event.event != "port":
            continue
        try:
            body = orjson.loads(event.data)
            yield PortEvent(body[port], int(body.get("lost", 0)), event.id)
        except (orjson.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
            raise ProtocolError(f"watch {instance}/{port}: a malformed event {event.data!r:.200}") from exc


async def session_events(gateway: HttpGateway, session: str, *,
                         idle_timeout: float = 60.0) -> AsyncIterator[SessionEvent]:
    """The events of the session *session* until it stops (see :meth:`AsyncClient.session_events`)."""
    async for event in _resuming(gateway, "/session/listen", {"s": session}, idle_timeout):
        try:
            data = orjson.loads(event.data) if event.data else None
        except orjson.JSONDecodeError as exc:
            raise ProtocolError(f"session {session}: a malformed {event.event} event {event.data!r:.200}") from exc
        yield SessionEvent(event.event, data)
        if event.event == "quit":
            return
