"""The guard in front of the routes: the door's decision, then the handler, its errors as genomix JSON.

It is the application's one middleware, however the application is served
(docs/decisions/0037): a refused request never reaches a route, a body announced
longer than :data:`MAX_BODY_BYTES` is refused before it is read, every exception
of a handler becomes the documented error reply, and a page of an allowed other
origin gets the CORS headers it needs to read the reply.  The routes that take a
body answer ``Expect: 100-continue`` with :func:`expect_body`, which aiohttp asks
before the middleware.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable

from aiohttp import web
from aiohttp.typedefs import Middleware

from ._access import allow_origin, preflight_reply, target_authority
from ._door import Door, Preflight, Refusal, repeated_fields
from ._errors import error_reply
from ._replies import json_reply

__all__ = ["guard_middleware", "expect_body", "Handler", "MAX_BODY_BYTES"]

Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]

#: The largest request body the gateway reads (a POST's JSON input): 1 MiB, aiohttp's own default.
MAX_BODY_BYTES = 1 << 20


def guard_middleware(door: Door) -> Middleware:
    """The middleware asking *door* about each request, then mapping the handler's errors."""

    @web.middleware
    async def guard(request: web.Request, handler: Handler) -> web.StreamResponse:
        headers = request.headers
        # Every name, repeats included (the keys of a MultiDict are distinct).
        names = [name for name, _ in request.query.items()] if request.query_string else ()
        # The scheme matters only to tell a page of the gateway's own origin from another's.
        scheme = request.scheme if "Origin" in headers else "http"
        # An absolute-form target (``GET http://name/path``) names the request's host, whatever Host says.
        target = request.raw_path
        authority = target_authority(target) if target[:1] != "/" else None
        verdict = door.decide(request.method, request.path, names, headers, scheme, authority=authority,
                              repeated=repeated_fields(headers))
        if type(verdict) is Refusal:
            response: web.StreamResponse = json_reply(verdict.body, status=verdict.status)
        elif (request.content_length or 0) > MAX_BODY_BYTES:
            response = _too_large(request.content_length or 0)
        elif type(verdict) is Preflight:
            return preflight_reply(verdict.origin)
        else:
            try:
                response = await handler(request)
            except Exception as exc:
                response = error_reply(request, exc)
        if verdict.origin is not None and not response.prepared:  # a stream set its own (``_sse``)
            allow_origin(response, verdict.origin)
        return response

    return guard


async def expect_body(request: web.Request) -> web.StreamResponse | None:
    """The answer of the routes that take a body to ``Expect: 100-continue``, before the guard runs.

    aiohttp asks a route's expect handler before its middleware: a body announced
    longer than :data:`MAX_BODY_BYTES` gets 413 at once (the client sends nothing),
    any other ``100 Continue`` (and an expectation other than ``100-continue`` 417).
    """
    length = request.content_length or 0
    if length > MAX_BODY_BYTES:
        return _too_large(length)
    if request.headers.get("Expect", "").lower() != "100-continue":
        return json_reply({"ex": "::genomix::http", "message": "the only expectation taken is 100-continue"},
                          status=417)
    if request.version >= (1, 1):
        await request.writer.write(b"HTTP/1.1 100 Continue\r\n\r\n")
        request.writer.output_size = 0  # the interim reply is not the reply's (as aiohttp's own handler does)
    return None


def _too_large(length: int) -> web.StreamResponse:
    """413 for a body announced longer than :data:`MAX_BODY_BYTES`, at once: before a ``100 Continue``.

    The body is not read: the connection closes after the reply.
    """
    response = json_reply({"ex": "::genomix::http", "message": f"a request body may be at most {MAX_BODY_BYTES} "
                                                               f"bytes; this one announces {length}"}, status=413)
    response.force_close()
    return response
