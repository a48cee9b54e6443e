"""The gateway's one middleware: access checks, the token, and errors as genomix JSON.

These were three aiohttp middlewares.  Each middleware is one more coroutine
frame (and ``functools.partial`` call) on every request, and under load the
gateway's own share of a request is a handful of microseconds: doing the three
in one coroutine keeps their order and replies and saves two frames a request.
The order is the one the three had: browsers are checked first (a refused page
learns nothing, not even whether a token is needed), then the token, and only
the handler's exceptions become error replies (a refusal is already a reply).
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable

from aiohttp import web
from aiohttp.typedefs import Middleware

from ._access import AccessPolicy, access_refusal, allow_origin
from ._auth import TokenCheck
from ._errors import error_reply

__all__ = ["guard_middleware"]

Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]


def guard_middleware(policy: AccessPolicy, token: TokenCheck | None) -> Middleware:
    """The middleware applying *policy*, then *token* (None: no token), then mapping the handler's errors."""

    @web.middleware
    async def guard(request: web.Request, handler: Handler) -> web.StreamResponse:
        refusal, origin = access_refusal(policy, request)
        if refusal is not None:
            return refusal
        if token is not None:
            refusal = token.screen(request)
            if refusal is not None:
                return refusal
        try:
            response = await handler(request)
        except Exception as exc:
            response = error_reply(request, exc)
        if origin is not None:
            allow_origin(response, origin)
        return response

    return guard
