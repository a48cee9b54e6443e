"""How the runtime's errors read on the wire: the HTTP status and genomix error body of each.

The gateway answers them so, and a component host answers a gateway's query so: a component
that runs in another process fails exactly as one in the gateway.
"""

from __future__ import annotations

from typing import Any

from ._budgets import OverBudget
from ._exceptions import (
    AmbiguousModule, ComponentError, GenomException, InputError, NoSuchModule, NoSuchPort, NoSuchRequest,
    NoSuchService, PortUnavailable, RemoteHostGone, RemoteRefusal, RemoteUnreachable, RequestRunning, disallowed,
    too_many_activities,
)
from ._host import LoadError, TooManyInstances

__all__ = ["error_body", "message_of", "REMOTE_IO"]

#: The exception of a request or read whose instance, in another process, cannot be reached.
REMOTE_IO = "::genom::remote_io"

_LOOKUPS: dict[type[Exception], str] = {
    NoSuchModule: "::genomix::no_such_module",
    NoSuchService: "::genom::no_such_service",
    NoSuchPort: "::genom::no_such_outport",
    NoSuchRequest: "::genomix::no_such_request",
}


def message_of(exc: BaseException) -> str:
    """The readable sentence of *exc*, safe to write in a reply (it may quote the client's text)."""
    return (str(exc) or type(exc).__name__).encode("utf-8", "backslashreplace").decode()


def error_body(exc: Exception) -> tuple[int, dict[str, Any]]:
    """The HTTP status and JSON body that report *exc* (500 ``::genom::unkex`` for what is not the runtime's).

    The body is ``{"ex": "<genom id>", "detail": {...}, "message": "<readable sentence>"}``.
    """
    message = message_of(exc)
    if isinstance(exc, RemoteRefusal):
        return exc.status, exc.body
    if isinstance(exc, RemoteHostGone):
        # Not a timeout (504) nor an unknown name (404): the instance's host is gone, and may come back.
        return 503, {"ex": REMOTE_IO, "detail": {"what": message, "host": exc.host, "last_heard": exc.last_heard},
                     "message": message}
    if isinstance(exc, RemoteUnreachable):
        return 504, {"ex": REMOTE_IO, "detail": {"what": message}, "message": message}
    if isinstance(exc, AmbiguousModule):
        return 409, {"ex": "::genomix::ambiguous_module", "message": message}
    for klass, ex in _LOOKUPS.items():
        if isinstance(exc, klass):
            return 404, {"ex": ex, "message": message}
    if isinstance(exc, InputError):
        return 400, {"ex": "::genom::serialization", "detail": {"what": message}, "message": message}
    if isinstance(exc, LoadError):
        return 400, {"ex": "::genomix::bad_load", "message": message}
    if isinstance(exc, TooManyInstances):
        return 429, {"ex": "::genomix::too_many_instances", "message": message}
    if isinstance(exc, RequestRunning):
        return 409, {"ex": "::genomix::request_running", "message": message}
    if isinstance(exc, OverBudget):
        return 429, {"ex": "::genomix::over_budget", "detail": {"what": message, "flag": exc.flag},
                     "message": message}
    if isinstance(exc, PortUnavailable):
        # The component's own exception says why (a sensor down): current data will come again.
        unavailable: dict[str, Any] = {"ex": exc.reason.id, "message": message}
        if (detail := exc.reason.encoded_detail()) is not None:
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
                 "message": "internal error (see the log)"}
