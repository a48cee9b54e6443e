"""Routes of loaded modules' requests: info, send, status, wait, abort and clean.

Everything under ``/module/M/`` resolves the instance ``M`` first (404 when it
is not loaded), then hands the request to the component runtime.
"""

from __future__ import annotations

import asyncio
import math
from typing import Any

from aiohttp import web

from ..components.core.runtime import LoadedInstance
from ._errors import BadQuery, UnsupportedBody
from ._guard import expect_body
from ._input import parse_input
from ._keys import HOST, INFO_BODIES, SESSIONS, SHUTDOWN
from ._replies import JSON_HEADERS, Reply, json_reply, text_reply
from ._shutdown import shutting_down_reply

__all__ = ["routes", "parse_input", "MAX_WAIT"]

#: The longest a ``wait`` may block, in seconds.
MAX_WAIT = 3600.0

routes = web.RouteTableDef()


def _component(request: web.Request) -> LoadedInstance:
    return request.app[HOST].get(request.match_info["module"])


@routes.get("/module/{module}/info")
async def info(request: web.Request) -> web.Response:
    """The description of the module's services, exceptions, ports and tasks (encoded once per instance)."""
    return Reply(body=request.app[INFO_BODIES].body(_component(request)), headers=JSON_HEADERS)


@routes.get("/module/{module}/send/{service}", allow_head=False)
async def send(request: web.Request) -> web.Response:
    """Send a request; reply with its status (``sent``, or already ``done``/``error``)."""
    return await _send(request, parse_input(request.query.get("input")))


@routes.post("/module/{module}/send/{service}", expect_handler=expect_body)
async def send_with_body(request: web.Request) -> web.Response:
    """Send a request whose input is the JSON body (``Content-Type: application/json``); as the GET form else.

    An extension of genomix (whose requests are all GETs) for OpenAPI generators and web
    apps; the content type makes every browser ask first (a CORS preflight), so a page of
    another site can never send one behind its user's back (docs/decisions/0024).  An empty
    body sends no input (every browser's POST carries an Origin, which the door checks).
    """
    if not request.body_exists:
        return await _send(request, None)  # no input, whatever type an empty body was given
    if request.content_type != "application/json":
        raise UnsupportedBody(f"a send's body is its input as JSON: Content-Type must be application/json, "
                              f"not {request.content_type!r}")
    try:
        text = (await request.read()).decode("utf-8")  # JSON is UTF-8 (RFC 8259), whatever charset is said
    except UnicodeDecodeError as exc:
        raise BadQuery(f"the body is not UTF-8 text (byte {exc.start})") from None
    raw = parse_input(text)
    if not isinstance(raw, dict):
        # The body is the input model (a bare value, as genomix's input= takes, stays the GET form's).
        raise BadQuery("a send's body is a JSON object of the service's inputs, by name")
    return await _send(request, raw)


async def _send(request: web.Request, raw: object) -> web.Response:
    component = _component(request)
    session = request.query.get("s") or None
    if session is not None:
        request.app[SESSIONS].get_or_create(session)
    started = await component.send(request.match_info["service"], raw, session=session,
                                   oneway="oneway" in request.query)
    return json_reply(started.status_object())


@routes.get("/module/{module}/status/{rqst}")
async def status(request: web.Request) -> web.Response:
    """The status object of a request."""
    found = await _component(request).request(request.match_info["rqst"])
    return json_reply(found.status_object())


@routes.get("/module/{module}/wait/{rqst}")
async def wait(request: web.Request) -> web.Response:
    """Block until the request ends (or ``timeout`` seconds pass); reply with its status.

    At shutdown the components stop first, so the reply is the request's final
    status; a request that still runs then gets a 503 ``::genomix::shutting_down``.
    """
    found = await _component(request).request(request.match_info["rqst"])
    try:
        timeout = float(request.query.get("timeout", MAX_WAIT))
    except ValueError:
        timeout = math.nan
    # NaN (which no comparison holds for) and negative times would end the wait at once, like an answer;
    # a longer wait than the most is refused rather than cut short without a word.
    if not 0 <= timeout <= MAX_WAIT:
        raise BadQuery(f"timeout must be a number of seconds from 0 to {MAX_WAIT:g}")
    shutdown = request.app[SHUTDOWN]
    ended = asyncio.ensure_future(found.ended.wait())
    # asyncio.timeout rather than wait_for, which on 3.11 can lose a cancellation racing the end.
    try:
        async with asyncio.timeout(timeout):
            waiters: set[asyncio.Future[Any]] = {ended, shutdown.future}
            await asyncio.wait(waiters, return_when=asyncio.FIRST_COMPLETED)
    except TimeoutError:
        pass
    finally:
        ended.cancel()
    if found.running and shutdown.is_set():
        return shutting_down_reply(found)
    return json_reply(found.status_object())


@routes.get("/module/{module}/abort/{rqst}", allow_head=False)
async def abort(request: web.Request) -> web.Response:
    """Interrupt a running request; reply with its final status."""
    aborted = await _component(request).abort(request.match_info["rqst"])
    return json_reply(aborted.status_object())


@routes.get("/module/{module}/clean/{rqst}", allow_head=False)
async def clean(request: web.Request) -> web.Response:
    """Forget an ended request, freeing its id."""
    await _component(request).clean(request.match_info["rqst"])
    return text_reply("")
