"""The server's request handler: what is answered ahead of the application's routes, and the connection told.

aiohttp's server calls one request handler for every request it has read (its
parser, the only reader of requests: docs/decisions/0037).  The gateway's one
answers plain port reads (:mod:`._fast_reads`), plain sends
(:mod:`._fast_sends`) and plain GETs of ``/`` and ``/version``
(:mod:`._fast_answers`) there, and hands every other request to the
application's own handler: the router, the guard, the routes.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable

from aiohttp import web
from aiohttp.http import HttpVersion10, HttpVersion11

from ._connection import UNSUPPORTED_VERSION, GatewayConnection
from ._fast_answers import FastAnswers
from ._fast_reads import FastReads
from ._fast_sends import FastSends

__all__ = ["ahead_of_the_routes", "RequestHandler"]

RequestHandler = Callable[[web.BaseRequest], Awaitable[web.StreamResponse]]

_VERSIONS = frozenset({HttpVersion10, HttpVersion11})


def ahead_of_the_routes(fast_reads: FastReads, fast_sends: FastSends, fast_answers: FastAnswers,
                        routes: RequestHandler) -> RequestHandler:
    """The server's request handler: a plain read, send or GET of the gateway's own answered here, else by *routes*.

    It also tells the gateway's connection when a request's head is complete and when its
    handler has returned (the head timeout, ``_connection``).
    """
    async def handle(request: web.BaseRequest) -> web.StreamResponse:
        # One coroutine for the lot: each layer of them costs every request its frames.
        protocol = request.protocol
        connection = protocol if type(protocol) is GatewayConnection else None  # else served some other way
        if connection is not None:
            connection.request_began()
        try:
            # HTTP/0.9: its reply would have no status line.
            if connection is not None and request.version not in _VERSIONS:
                return connection.refuse(505, UNSUPPORTED_VERSION)
            reply = fast_reads.reply(request)  # (the most frequent first)
            if reply is not None:
                return reply
            send = fast_sends.plain(request)
            if send is not None:
                return await fast_sends.reply(request, send)
            answer = fast_answers.reply(request)
            if answer is not None:
                return answer
            return await routes(request)
        finally:
            if connection is not None:
                connection.request_ended(request)

    return handle
