"""Gateway errors and how every error becomes a genomix-style reply (status code and JSON body).

::

    GatewayError
    ├── NoSuchSession (LookupError)   404
    ├── BadQuery (ValueError)         400  malformed query parameters or input JSON
    ├── UnsupportedBody               415  a send's body that is not JSON
    ├── LoadForbidden                 403  a load by path (only registered components load)
    └── TooManySessions               429  the session cap is reached

Errors of the component runtime map as the runtime says (``error_body`` of
``aiogenomix.components.core.runtime``, which component hosts answer too): unknown
module/service/port/request 404, bad input 400, too many activities 429, a killed
component or a running request that cannot be cleaned 409, a bound in all reached
(``OverBudget``) 429, a read of a port whose data its component withdrew (a sensor
down) 503, an instance of another process that cannot be reached 504
``::genom::remote_io``, and what such an instance refused as its host answered it.
The body is always
``{"ex": "<genom id>", "detail": {...}, "message": "<readable sentence>"}``.
A ``validate`` refusal is not an HTTP error: like in genom3 it ends the
request in ``error`` (docs/decisions/0011).
"""

from __future__ import annotations

import logging
from typing import Any

from aiohttp import web

from ..components.core import ThrottledLog
from ..components.core.runtime import error_body as runtime_error_body
from ..components.core.runtime import message_of
from ._replies import json_reply

__all__ = [
    "GatewayError", "NoSuchSession", "BadQuery", "UnsupportedBody", "LoadForbidden", "TooManySessions",
    "error_reply", "error_body",
]

log = logging.getLogger(__name__)
#: Faults of the gateway that a client's requests set off: one traceback per place, then rate-limited lines.
_faults = ThrottledLog(log)


class GatewayError(Exception):
    """Base of the errors the gateway itself raises."""


class NoSuchSession(GatewayError, LookupError):
    """No session of that name."""


class BadQuery(GatewayError, ValueError):
    """A malformed query (bad JSON in ``input``, a bad ``timeout``...)."""


class UnsupportedBody(GatewayError):
    """A request body of a type the endpoint does not take (a send's body must be JSON)."""


class LoadForbidden(GatewayError):
    """Loading by path is refused: only registered components can be loaded."""


class TooManySessions(GatewayError):
    """A new session would pass the cap on sessions."""


def error_body(exc: Exception) -> tuple[int, dict[str, Any]]:
    """The HTTP status and JSON body that report *exc*."""
    if isinstance(exc, GatewayError):
        message = message_of(exc)
        if isinstance(exc, NoSuchSession):
            return 404, {"ex": "::genomix::no_such_session", "message": message}
        if isinstance(exc, BadQuery):
            return 400, {"ex": "::genom::serialization", "detail": {"what": message}, "message": message}
        if isinstance(exc, UnsupportedBody):
            return 415, {"ex": "::genomix::unsupported_media_type", "message": message}
        if isinstance(exc, TooManySessions):
            return 429, {"ex": "::genomix::too_many_sessions", "message": message}
        if isinstance(exc, LoadForbidden):
            return 403, {"ex": "::genomix::forbidden", "message": message}
    status, body = runtime_error_body(exc)
    if status == 500:
        body["message"] = "internal error (see the gateway log)"
    return status, body


def error_reply(request: web.BaseRequest, exc: Exception) -> web.Response:
    """The JSON reply to the exception *exc* a handler raised (an HTTP exception below 400 is raised again)."""
    if isinstance(exc, web.HTTPException):
        if exc.status < 400:
            raise exc
        reply = json_reply({"ex": "::genomix::http", "message": exc.reason}, status=exc.status)
        if "Allow" in exc.headers:
            reply.headers["Allow"] = exc.headers["Allow"]
        return reply
    status, body = error_body(exc)
    if status >= 500 and body.get("ex") == "::genom::unkex":
        _faults.error("%s %s failed: %s", request.method, request.path_qs[:200], body["detail"]["what"], exc=exc)
    elif status == 504:  # a component host that does not answer: one line, no traceback (nothing of ours failed)
        _faults.warning("%s %s: %s", request.method, request.path_qs[:200], body["message"])
    return json_reply(body, status=status)
