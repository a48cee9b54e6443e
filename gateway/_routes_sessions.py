"""Routes of sessions: ``/session/start``, ``/session/stop`` and the ``/session/listen`` event stream."""

from __future__ import annotations

import asyncio
import contextlib

from aiohttp import web

from ._errors import BadQuery
from ._keys import CONFIG, SESSIONS
from ._replies import SERVER_HEADER, text_reply
from ._sse import FINAL_ID, GENOMIX_FORM, PING, STANDARD_FORM, event_stream

__all__ = ["routes"]

routes = web.RouteTableDef()


def _session_name(request: web.Request, required: bool = True) -> str:
    name = request.query.get("s", "")
    if required and not name:
        raise BadQuery("this request needs a session name: ?s=NAME")
    return name


@routes.get("/session/start", allow_head=False)
async def start(request: web.Request) -> web.Response:
    """Start a session; an empty ``s`` lets the gateway choose a unique name. Reply: the name."""
    session = request.app[SESSIONS].start(_session_name(request, required=False))
    return text_reply(session.name)


@routes.get("/session/stop", allow_head=False)
async def stop(request: web.Request) -> web.Response:
    """Stop a session: its listeners get ``quit`` and their streams end."""
    request.app[SESSIONS].stop(_session_name(request))
    return text_reply("")


@routes.get("/session/listen", allow_head=False)
async def listen(request: web.Request) -> web.StreamResponse:
    """Stream the session's events (``request``, ``unload``, ``quit``) until it stops or the client leaves.

    A standard stream opened again with ``Last-Event-ID`` first gets the events after that id
    that the session still keeps.  A reconnect after ``quit`` (``Last-Event-ID`` of the final
    event) gets 204, and the session is not started again: an EventSource stops there.
    """
    name = _session_name(request)
    last_id = request.headers.get("Last-Event-ID")
    if last_id == FINAL_ID:
        return web.Response(status=204, headers=SERVER_HEADER)
    sessions = request.app[SESSIONS]
    session = sessions.get_or_create(name)
    transport = request.transport
    stream = event_stream(request)
    listener = sessions.attach(session, alive=lambda: transport is not None and not transport.is_closing(),
                               form=STANDARD_FORM if stream.standard else GENOMIX_FORM,
                               last_id=last_id if stream.standard else None)
    ping_interval = request.app[CONFIG].sessions.ping_interval
    try:
        await stream.prepare(request)
        while True:
            try:
                async with asyncio.timeout(ping_interval):
                    await listener.ready.wait()
            except TimeoutError:
                await stream.write(PING)
                continue
            data = listener.take()
            if data:
                await stream.write(data)  # waits while the connection's buffer is full
            if listener.ended:
                break
    except ConnectionError:
        pass  # the client went away: nothing to report to anyone
    finally:
        sessions.detach(session, listener)
    with contextlib.suppress(ConnectionError):
        await stream.write_eof()
    return stream
