"""Port reads answered ahead of the routes, without aiohttp's routing and response machinery.

A client polling the audio window sends one small GET after another.  Timed
inside the gateway (the 500 ms window, read back to back), about 200 µs passed
between such a request's bytes and its reply's first byte, and most of it went to
the machinery around the read itself: finding the route among the eight under
``/module``, the middleware, and building the ``Response`` and its head
(docs/decisions/0021).

:class:`FastReads` answers the reads that need none of it, as the server's request
handler, ahead of the application's routes (:func:`~._ahead.ahead_of_the_routes`): a
``GET /module/M/read/P`` over HTTP/1.1, kept alive, of a single out port of a
loaded instance, with no parameters but ``format``, ``since``, ``s`` and ``_``
(plain: no percent-encoding), that the door (``_door``) admits as a program's
request, on a connection whose socket has nothing left to send.  The request is
aiohttp's, read by its parser like every other: there is no second reader of
heads.  The body is the route's own (:func:`~._routes_ports.read_body`, with the
same bodies kept per publication) and the head is the one aiohttp writes for it;
both go to the socket in one gathered write.  Every other request goes to the
routes, including every one the door refuses and every read the routes answer
with an error: refusals and errors are the routes' alone, and the rules are the
door's alone.
"""

from __future__ import annotations

from aiohttp import web
from aiohttp.http import HttpVersion11

from ..components.core import Incremental, OutPortRuntime
from ._connection import Written
from ._door import ADMITTED, Door, repeated_fields
from ._gather import direct_socket
from ._keys import DOOR, HOST, READ_BODIES
from ._pieces import PiecesPayload
from ._replies import http_date
from ._routes_ports import READ_HEADERS, parse_since, read_body, wants_binary

__all__ = ["FastReads", "plain_parameters", "head_start"]

#: The parameters a fast read may carry (``name=`` is for multiple ports: the routes answer it).
_PARAMETERS = frozenset({"format", "since", "s", "_"})


class FastReads:
    """Answers the plain port reads of the gateway *app* (see the module's description).

    Args:
        app: The gateway application (its host, door and read cache).
    """

    def __init__(self, app: web.Application) -> None:
        self._host = app[HOST]
        self._door: Door = app[DOOR]
        self._bodies = app[READ_BODIES]
        self._heads = {binary: head_start(READ_HEADERS[binary]) for binary in (False, True)}

    def reply(self, request: web.BaseRequest) -> Written | None:
        """The whole reply to *request*, or None to leave it to the routes."""
        target = request.raw_path
        # The cheapest looks first: every other request passes here on its way to the routes.
        if ("/read/" not in target or not target.startswith("/module/") or request.method != "GET"
                or request.version != HttpVersion11 or not request.keep_alive):
            return None
        path, _, query = target.partition("?")
        parts = path.split("/")
        if len(parts) != 5 or parts[3] != "read" or "%" in path or "#" in query:
            return None
        parameters = plain_parameters(query, _PARAMETERS)
        if parameters is None or request.body_exists:
            return None
        headers = request.headers
        if "Expect" in headers:  # answered by the route's expect handler (100 Continue, or 417)
            return None
        if self._door.decide("GET", path, parameters, headers, repeated=repeated_fields(headers)) is not ADMITTED:
            return None
        fmt = parameters.get("format", "")
        if fmt not in ("", "json", "binary") or direct_socket(request.transport) is None:
            # Bytes still queued for the socket: the routes' writer waits for them to drain.
            return None
        binary = wants_binary(fmt, headers.get("Accept", ""))
        try:
            since = parse_since(parameters.get("since"))
            body = self._body(parts[2], parts[4], since, binary)
        except Exception:  # noqa: BLE001  # a bad since, no such instance or port, a read that fails: the routes'
            return None
        if body is None:
            return None
        length = len(body) if isinstance(body, bytes) else body.size
        http_head = self._heads[binary] + b"Content-Length: %d\r\nDate: %s\r\n\r\n" % (length, http_date().encode())
        if isinstance(body, bytes):
            return Written([http_head + body])  # small: one buffer, one write
        return Written([http_head, *body.pieces], size=len(http_head) + length)

    def _body(self, instance: str, name: str, since: int | None, binary: bool) -> bytes | PiecesPayload | None:
        """The body of the read of port *name* of *instance*, or None for a port the routes answer."""
        port = self._host.get(instance).port(name)
        if not isinstance(port, OutPortRuntime) or port.spec.multiple:
            return None
        value = port.read()
        if since is not None and not isinstance(value, Incremental):
            return None
        return read_body(self._bodies, name, port, value, None, since, binary)


def plain_parameters(query: str, taken: frozenset[str]) -> dict[str, str] | None:
    """The *query*'s parameters when they are among *taken*, each once and plain; else None (the routes')."""
    found: dict[str, str] = {}
    if not query:
        return found
    if ";" in query:  # a separator to some readers of queries: the routes decide
        return None
    for item in query.split("&"):
        name, _, value = item.partition("=")
        # Encoded characters (%xx, + for a space) are decoded by the routes.
        if name not in taken or name in found or "%" in value or "+" in value:
            return None
        found[name] = value
    return found


def head_start(headers: dict[str, str]) -> bytes:
    """The status line and the fixed headers of a 200 reply with *headers*, in aiohttp's order."""
    lines = "".join(f"{name}: {value}\r\n" for name, value in headers.items())
    return f"HTTP/1.1 200 OK\r\n{lines}".encode()
