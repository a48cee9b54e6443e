"""The gateway's own GETs (``/``, ``/version``) answered ahead of the routes, with the routes' replies.

A client asks ``/version`` when it connects, and ``/`` for what is loaded and
for the rig's clock (the Python client at each of its calls for them, the
console after each change).  Through the routes, such a request pays
aiohttp's router, the guard's middleware layers and their bookkeeping, for an
answer made from the application alone.

:class:`FastAnswers` answers the plain ones as the server's request handler
answers plain reads and sends (:mod:`._fast_reads`, :mod:`._fast_sends`): a
``GET`` over HTTP/1.1, kept alive, without a body or an ``Expect``, of one of the
paths the routes declare (:data:`~._routes_admin.ANSWERED_AHEAD`: a table of
exact paths, not a second router) with no parameter but ``_`` (the
cache-buster), that the door (``_door``) admits as a program's request.  Its reply
is made by the route's own function, so both ways give the same bytes
(``tests/gateway/test_fast_answers.py`` compares them).  Every other request goes
to the routes, and with it every refusal: the rules are the door's alone.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

from aiohttp import web
from aiohttp.http import HttpVersion11

from ._door import ADMITTED, Door, repeated_fields
from ._errors import error_reply
from ._keys import DOOR

__all__ = ["FastAnswers", "Answer"]

#: How a route's reply is made from the application alone.
Answer = Callable[[web.Application], web.StreamResponse]
#: The parameters a fast answer may carry (the cache-buster: it asks for nothing).
_PARAMETERS = ("_",)


class FastAnswers:
    """Answers the plain GETs of *answers*' paths for the gateway *app* (see the module's description).

    Args:
        app: The gateway application (its door, and what the answers read).
        answers: The reply of each path answered ahead of the routes.
    """

    def __init__(self, app: web.Application, answers: Mapping[str, Answer]) -> None:
        self._app = app
        self._door: Door = app[DOOR]
        self._answers = dict(answers)

    def reply(self, request: web.BaseRequest) -> web.StreamResponse | None:
        """The reply to *request* when it is a plain GET of a path answered here; None to leave it to the routes."""
        path, _, query = request.raw_path.partition("?")
        answer = self._answers.get(path)
        # The cheapest looks first: every other request passes here on its way to the routes.
        if (answer is None or request.method != "GET" or request.version != HttpVersion11
                or not request.keep_alive or request.body_exists):
            return None
        if query and (query.partition("=")[0] not in _PARAMETERS or "&" in query or ";" in query):
            return None  # anything else the door (or the route) is to judge
        headers = request.headers
        if "Expect" in headers:  # answered by the route's expect handler
            return None
        names = _PARAMETERS if query else ()
        if self._door.decide("GET", path, names, headers, repeated=repeated_fields(headers)) is not ADMITTED:
            return None
        try:
            return answer(self._app)
        except Exception as exc:  # noqa: BLE001  # what the guard makes of the route's exceptions
            return error_reply(request, exc)
