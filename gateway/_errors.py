"""Gateway errors and how every error becomes a genomix-style reply (status code and JSON body).

::

    GatewayError
    ├── NoSuchSession (LookupError)   404
    ├── BadQuery (ValueError)         400  malformed query parameters or input JSON
    ├── UnsupportedBody               415  a send's body that is not JSON
    ├── LoadForbidden                 403  a load by path (only registered components load)
    ├── TooManySessions               429  the session cap is reached
    ├── RemoteRefusal                 the error of a component in another process, as answered there
    └── RemoteUnreachable             504  ::genom::remote_io: another process did not answer in time

Errors of the component runtime map as: unknown module/service/port/request
404, bad input 400, too many activities 429, a killed component or a running
request that cannot be cleaned 409, a bound in all reached (``OverBudget``) 429,
a read of a port whose data its component withdrew (a sensor down) 503.  The body is always
``{"ex": "<genom id>", "detail": {...}, "message": "<readable sentence>"}``.
A ``validate`` refusal is not an HTTP error: like in genom3 it ends the
request in ``error`` (docs/decisions/0011).
"""

from __future__ import annotations

import logging
from typing import Any

from aiohttp import web

from ..components.core import GenomException, LoadError, OverBudget, ThrottledLog, disallowed, too_many_activities
from ..components.core.runtime import (
    ComponentError, InputError, NoSuchModule, NoSuchPort, NoSuchRequest, NoSuchService, PortUnavailable,
    RequestRunning, TooManyInstances,
)

from ._replies import json_reply

__all__ = [
    "GatewayError", "NoSuchSession", "BadQuery", "UnsupportedBody", "LoadForbidden", "TooManySessions", "RemoteRefusal",
    "RemoteUnreachable", "ZenohSessionError", "error_reply", "error_body",
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


class RemoteRefusal(GatewayError):
    """A component of another process refused: its genomix error, answered as the gateway there answers it.

    Args:
        status: The HTTP status of the error.
        body: The genomix error body (``ex``, ``detail``, ``message``).
    """

    def __init__(self, status: int, body: dict[str, Any]) -> None:
        super().__init__(body.get("message", body.get("ex", "")))
        self.status, self.body = status, body


class RemoteUnreachable(GatewayError):
    """A component of another process did not answer in time (its process died, or the network is cut)."""


class ZenohSessionError(GatewayError):
    """The Zenoh session cannot be opened (a malformed endpoint, an address that cannot be listened on)."""


_LOOKUPS: dict[type[Exception], str] = {
    NoSuchModule: "::genomix::no_such_module",
    NoSuchService: "::genom::no_such_service",
    NoSuchPort: "::genom::no_such_outport",
    NoSuchRequest: "::genomix::no_such_request",
    NoSuchSession: "::genomix::no_such_session",
}


def error_body(exc: Exception) -> tuple[int, dict[str, Any]]:
    """The HTTP status and JSON body that report *exc*."""
    # Messages may quote the client's text: never let it make the reply itself unwritable.
    message = (str(exc) or type(exc).__name__).encode("utf-8", "backslashreplace").decode()
    if isinstance(exc, RemoteRefusal):
        return exc.status, exc.body
    if isinstance(exc, RemoteUnreachable):
        return 504, {"ex": "::genom::remote_io", "detail": {"what": message}, "message": message}
    for klass, ex in _LOOKUPS.items():
        if isinstance(exc, klass):
            return 404, {"ex": ex, "message": message}
    if isinstance(exc, InputError):
        return 400, {"ex": "::genom::serialization", "detail": {"what": message}, "message": message}
    if isinstance(exc, BadQuery):
        return 400, {"ex": "::genom::serialization", "detail": {"what": message}, "message": message}
    if isinstance(exc, UnsupportedBody):
        return 415, {"ex": "::genomix::unsupported_media_type", "message": message}
    if isinstance(exc, LoadError):
        return 400, {"ex": "::genomix::bad_load", "message": message}
    if isinstance(exc, TooManyInstances):
        return 429, {"ex": "::genomix::too_many_instances", "message": message}
    if isinstance(exc, TooManySessions):
        return 429, {"ex": "::genomix::too_many_sessions", "message": message}
    if isinstance(exc, LoadForbidden):
        return 403, {"ex": "::genomix::forbidden", "message": message}
    if isinstance(exc, RequestRunning):
        return 409, {"ex": "::genomix::request_running", "message": message}
    if isinstance(exc, OverBudget):
        return 429, {"ex": "::genomix::over_budget", "detail": {"what": message, "flag": exc.flag},
                     "message": message}
    if isinstance(exc, PortUnavailable):
        reason = exc.reason
        unavailable: dict[str, Any] = {"ex": reason.id, "message": message}
        if (detail := reason.encoded_detail()) is not None:
            unavailable["detail"] = detail
        return 503, unavailable
    if isinstance(exc, GenomException):
        body: dict[str, Any] = {"ex": exc.id}
        detail = exc.encoded_detail()
        if detail is not None:
            body["detail"] = detail
        if isinstance(exc, too_many_activities):
            return 429, body | {"message": "too many activities are running in this component"}
        if isinstance(exc, disallowed):
            return 409, body | {"message": "the component was killed and no longer accepts requests"}
        # A genom exception raised outside any request (a port read, for one): the request was refused.
        return 400, body | {"message": message}
    if isinstance(exc, ComponentError):
        return 400, {"ex": "::genomix::error", "message": message}
    return 500, {"ex": "::genom::unkex", "detail": {"what": f"{type(exc).__name__}: {exc}"},
                 "message": "internal error (see the gateway log)"}


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
