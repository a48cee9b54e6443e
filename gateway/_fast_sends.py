"""Sends answered ahead of the routes, without aiohttp's routing, middleware and response machinery.

A client driving a component sends one small ``GET /module/M/send/S`` after
another (50 of them at once in the load benchmark).  Through the routes, such a
request paid aiohttp's router (eight routes under ``/module``), two middleware
layers (the guard, and the one aiohttp adds to any application with middleware),
a ``Response`` and its head: most of what the gateway spent beyond bare aiohttp
(docs/decisions/0041).

:class:`FastSends` answers the sends that need none of it, as the server's
request handler does the plain reads (:mod:`._fast_reads`): a ``GET`` over
HTTP/1.1, kept alive, with no body, of a service of a loaded instance, with no
parameters but ``input``, ``oneway``, ``s`` and ``_`` (plain: no
percent-encoding), that the door (``_door``) admits as a program's request, on a
connection whose socket has nothing left to send.  From there it does what the
``send`` route does, in the same order (the input, the session, the component's
``send``), and answers with the same bytes: the route's head and JSON, or the
guard's error reply for what the route would have raised.  Every other request
goes to the routes, and with it every refusal: the rules are the door's alone.
"""

from __future__ import annotations

from aiohttp import web
from aiohttp.http import HttpVersion11

from ..components.core import ComponentHost
from ._connection import Written
from ._door import ADMITTED, Door, repeated_fields
from ._errors import error_reply
from ._fast_reads import head_start, plain_parameters
from ._gather import direct_socket
from ._input import parse_input
from ._keys import DOOR, HOST, SESSIONS
from ._replies import JSON_HEADERS, dumps, http_date
from ._sessions import SessionStore

__all__ = ["FastSends", "PlainSend"]

#: The parameters a fast send may carry (those of the ``send`` route).
_PARAMETERS = frozenset({"input", "oneway", "s", "_"})


class PlainSend:
    """A send that :class:`FastSends` answers: the instance, the service and the query's parameters."""

    __slots__ = ("instance", "service", "parameters")

    def __init__(self, instance: str, service: str, parameters: dict[str, str]) -> None:
        self.instance, self.service, self.parameters = instance, service, parameters


class FastSends:
    """Answers the plain sends of the gateway *app* (see the module's description).

    Args:
        app: The gateway application (its host, door and sessions).
    """

    def __init__(self, app: web.Application) -> None:
        self._host: ComponentHost = app[HOST]
        self._door: Door = app[DOOR]
        self._sessions: SessionStore = app[SESSIONS]
        self._head = head_start(JSON_HEADERS)

    def plain(self, request: web.BaseRequest) -> PlainSend | None:
        """The send *request* asks for when it is a plain one (nothing run yet); None to leave it to the routes."""
        target = request.raw_path
        # The cheapest looks first: every other request passes here on its way to the routes.
        if ("/send/" not in target or not target.startswith("/module/") or request.method != "GET"
                or request.version != HttpVersion11 or not request.keep_alive):
            return None
        path, _, query = target.partition("?")
        parts = path.split("/")
        # Dot segments and empty names are the router's to resolve (to another path, or to none).
        if len(parts) != 5 or parts[3] != "send" or "%" in path or "/." in path or "#" in query:
            return None
        instance, service = parts[2], parts[4]
        if not instance or not service:
            return None  # the routes' 404
        parameters = plain_parameters(query, _PARAMETERS)
        if parameters is None or request.body_exists:
            return None
        headers = request.headers
        if "Expect" in headers:  # answered by the route's expect handler
            return None
        if self._door.decide("GET", path, parameters, headers, repeated=repeated_fields(headers)) is not ADMITTED:
            return None
        if direct_socket(request.transport) is None:
            return None  # bytes still queued for the socket: the routes' writer waits for them to drain
        return PlainSend(instance, service, parameters)

    async def reply(self, request: web.BaseRequest, send: PlainSend) -> web.StreamResponse:
        """Send the request *send* names, as the ``send`` route does (in its order); the whole reply."""
        parameters = send.parameters
        try:
            raw = parse_input(parameters.get("input"))
            component = self._host.get(send.instance)
            session = parameters.get("s") or None
            if session is not None:
                self._sessions.get_or_create(session)
            started = await component.send(send.service, raw, session=session, oneway="oneway" in parameters)
        except Exception as exc:  # noqa: BLE001  # what the guard makes of the route's exceptions
            return error_reply(request, exc)
        body = dumps(started.status_object())
        return Written([self._head + b"Content-Length: %d\r\nDate: %s\r\n\r\n%s" % (
            len(body), http_date().encode(), body)])
