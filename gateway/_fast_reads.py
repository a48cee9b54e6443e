"""Port reads answered where their request is read, without aiohttp's request machinery.

A client polling the audio window sends one small GET after another.  Timed
inside the gateway (the 500 ms window, read back to back), about 200 µs passed
between such a request's bytes and its reply's first byte, and about 130 µs went to
the machinery around the read itself: waking the connection's task (and, before
Python 3.12, starting a task per request), building the ``Request``, finding
the route among the eight under ``/module``, the middleware, and building the
``Response`` and its head.

:class:`FastReads` answers the reads that need none of it, straight from the
connection (``_connection``): a ``GET /module/M/read/P`` over HTTP/1.1, kept
alive, without a body, of a single out port of a loaded instance, with no
parameters but ``format``, ``since``, ``s`` and ``_`` (plain: no percent-encoding),
that the door (``_door``) admits as a program's request.  The body is the
route's own (:func:`~._routes_ports.read_body`, with the same bodies kept per
publication) and the head is the one aiohttp writes for it.  Every other
request goes the usual way, including every one the door refuses and every
read the routes answer with an error: refusals and errors are the routes'
alone, and the rules are the door's alone.
"""

from __future__ import annotations

from aiohttp import web
from aiohttp.helpers import rfc822_formatted_time

from ..components.core import Incremental, OutPortRuntime
from ._door import ADMITTED, Door
from ._gather import Buffer
from ._keys import DOOR, HOST, READ_BODIES
from ._pieces import PiecesPayload
from ._request_head import RequestHead
from ._routes_ports import READ_HEADERS, parse_since, read_body, wants_binary

__all__ = ["FastReads"]

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
        self._heads = {binary: _head_start(READ_HEADERS[binary]) for binary in (False, True)}

    @staticmethod
    def may_answer(head: RequestHead) -> bool:
        """Whether *head* may be a plain read (a cheap look, before the socket and the door are asked)."""
        return head.method == "GET" and head.target.startswith("/module/") and "/read/" in head.target

    def reply(self, head: RequestHead) -> list[Buffer] | None:
        """The whole reply to *head* (its HTTP head first), or None to leave the request to the routes."""
        if head.method != "GET" or head.version != "1.1" or head.body_length:
            return None
        path, _, query = head.target.partition("?")
        parts = path.split("/")
        if len(parts) != 5 or parts[1] != "module" or parts[3] != "read" or "%" in path or "#" in query:
            return None
        parameters = _parameters(query)
        if parameters is None:
            return None
        headers, repeated = head.headers()
        if (not head.keeps_alive(headers)
                or self._door.decide("GET", path, parameters, headers, repeated=repeated) is not ADMITTED):
            return None
        fmt = parameters.get("format", "")
        if fmt not in ("", "json", "binary"):
            return None
        binary = wants_binary(fmt, headers.get("accept", ""))
        try:
            since = parse_since(parameters.get("since"))
            body = self._body(parts[2], parts[4], since, binary)
        except Exception:  # noqa: BLE001  # a bad since, no such instance or port, a read that fails: the routes'
            return None
        if body is None:
            return None
        pieces = body.pieces if isinstance(body, PiecesPayload) else (body,)
        # The Date aiohttp writes (its helper, made once a second).
        http_head = self._heads[binary] + b"Content-Length: %d\r\nDate: %s\r\n\r\n" % (
            sum(len(piece) for piece in pieces), rfc822_formatted_time().encode())
        if isinstance(body, bytes):
            return [http_head + body]  # small: one buffer, one write
        return [http_head, *pieces]

    def _body(self, instance: str, name: str, since: int | None, binary: bool) -> bytes | PiecesPayload | None:
        """The body of the read of port *name* of *instance*, or None for a port the routes answer."""
        port = self._host.get(instance).port(name)
        if not isinstance(port, OutPortRuntime) or port.spec.multiple:
            return None
        value = port.read()
        if since is not None and not isinstance(value, Incremental):
            return None
        return read_body(self._bodies, name, port, value, None, since, binary)


def _parameters(query: str) -> dict[str, str] | None:
    """The query's parameters when they are among those of a fast read, each once and plain; else None."""
    found: dict[str, str] = {}
    if not query:
        return found
    for item in query.split("&"):
        name, _, value = item.partition("=")
        # Encoded characters (%xx, + for a space) are decoded by the routes.
        if name not in _PARAMETERS or name in found or "%" in value or "+" in value:
            return None
        found[name] = value
    return found


def _head_start(headers: dict[str, str]) -> bytes:
    """The status line and the fixed headers of a read's reply, in aiohttp's order."""
    lines = "".join(f"{name}: {value}\r\n" for name, value in headers.items())
    return f"HTTP/1.1 200 OK\r\n{lines}".encode()
