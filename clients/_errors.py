"""The client's exception tree, and the classes generated per genom exception id.

::

    GenomixError                      everything this client raises (alias: GenoMError)
    ├── RemoteError                   a genom exception: .ex .detail .request_id .module .service
    │   ├── Interrupted               ::genom::interrupted; .by names the interrupter
    │   ├── InvalidInput (ValueError) ::genom::serialization, ::genomix::bad_load (HTTP 400)
    │   ├── NotFound (LookupError)    no such module, service, port, request or session (HTTP 404)
    │   ├── Forbidden                 ::genomix::forbidden, ::genomix::unauthorized (HTTP 403, 401)
    │   ├── TooManyActivities         ::genom::too_many_activities (HTTP 429)
    │   ├── HostUnreachable           ::genom::remote_io: a component host did not answer (504) or is gone (503)
    │   └── <generated>               one class per declared exception, e.g. ``demo.TOO_FAR_AWAY``
    ├── TransportError (ConnectionError)  the gateway cannot be reached, or the connection broke
    ├── RequestTimeout (TimeoutError)     a blocking call did not end in time; .request still runs
    ├── ProtocolError                 a reply that does not follow the wire contract
    ├── ModuleUnloaded                the module of a pending request was unloaded
    └── ClientClosed                  the client was closed, or its session was stopped

A declared exception arrives as the ``error`` status of a request, whether the
service's ``validate`` refused the input or the running service threw it: both
raise the same generated class.  A genom exception in an HTTP error body (such
as ``too_many_activities``) raises its class too, with no ``request_id``.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping, Sequence
from typing import Any

__all__ = [
    "ClientClosed",
    "Forbidden",
    "GenoMError",
    "GenomixError",
    "HostUnreachable",
    "Interrupted",
    "InvalidInput",
    "ModuleUnloaded",
    "NotFound",
    "ProtocolError",
    "RemoteError",
    "RequestTimeout",
    "TooManyActivities",
    "TransportError",
    "remote_error",
    "remote_exception_class",
]


class GenomixError(Exception):
    """Base of every exception raised by :mod:`aiogenomix.clients`."""


#: python-genomix raises ``genomix.event.GenoMError``; scripts catching it keep working.
GenoMError = GenomixError


class RemoteError(GenomixError):
    """A genom exception reported by the gateway or thrown by a service.

    Detail members are also readable as attributes (``exc.overshoot``).

    Attributes:
        ex: The exception id, e.g. ``::demo::TOO_FAR_AWAY``.
        detail: The exception's members (empty when it has none).
        request_id: The request that ended with it (None for a refused HTTP request).
        module: The module instance involved, when known.
        service: The service or port involved, when known.
        message: The gateway's readable sentence, when it sent one.
    """

    #: The exception id this class stands for (generated classes set it).
    ex: str = ""

    def __init__(self, ex: str = "", detail: Mapping[str, Any] | None = None, *, request_id: str | None = None,
                 module: str | None = None, service: str | None = None, message: str | None = None) -> None:
        self.ex = ex or type(self).ex
        self.detail: dict[str, Any] = dict(detail or {})
        self.request_id = request_id
        self.module = module
        self.service = service
        self.message = message
        super().__init__(self._describe())

    def _describe(self) -> str:
        text = self.ex
        if self.detail:
            text += " " + ", ".join(f"{k}={v!r}" for k, v in self.detail.items())
        where = [w for w in (self.service, self.request_id) if w]
        if where:
            text += f" ({', '.join(where)})"
        if self.message:
            text += f": {self.message}"
        return text

    def __getattr__(self, name: str) -> Any:
        # Only detail members, and never private names (pickling and IPython probe those).
        if not name.startswith("_"):
            detail = self.__dict__.get("detail", {})
            if name in detail:
                return detail[name]
        raise AttributeError(f"{type(self).__name__} has no attribute {name!r}")

    def __reduce__(self) -> tuple[Any, ...]:
        return (_rebuild, (type(self), self.ex, self.detail, self.request_id, self.module, self.service,
                           self.message))


def _rebuild(cls: type[RemoteError], *args: Any) -> RemoteError:
    ex, detail, request_id, module, service, message = args
    return cls(ex, detail, request_id=request_id, module=module, service=service, message=message)


class Interrupted(RemoteError):
    """The request was interrupted (``::genom::interrupted``).

    Attributes:
        by: Who interrupted it: a service name (``Stop``), ``abort`` (the abort
            request), ``abort_activity`` or ``kill``.
    """

    ex = "::genom::interrupted"

    @property
    def by(self) -> str | None:
        """The interrupting service (or ``abort``, ``abort_activity``, ``kill``)."""
        by = self.detail.get("by")
        return str(by) if by is not None else None

    def _describe(self) -> str:
        what = f"{self.service} ({self.request_id})" if self.service and self.request_id else (
            self.request_id or self.service or "the request")
        return f"{what} was interrupted by {self.detail.get('by', 'an unknown cause')} ({self.ex})"


class InvalidInput(RemoteError, ValueError):
    """The gateway refused the input (``::genom::serialization``) or the load arguments."""


class NotFound(RemoteError, LookupError):
    """No such module, service, port, request or session (HTTP 404)."""


class Forbidden(RemoteError):
    """The gateway refused the request: a load by path, or a missing or wrong token."""


class TooManyActivities(RemoteError):
    """The component runs as many activities as it can (HTTP 429)."""


class HostUnreachable(RemoteError):
    """The component host that runs the instance did not answer, was not heard from, or is gone.

    ``::genom::remote_io``: HTTP 504 for a host that did not answer in time or fell silent (a cut
    network, a frozen process); HTTP 503 for an instance whose host is gone (it may come back, and the
    gateway loads it again then), with the detail members ``host`` and ``last_heard`` (ISO 8601, UTC).
    A request that was running there ends with it too.
    """


class TransportError(GenomixError, ConnectionError):
    """The gateway cannot be reached, or the connection broke before the reply."""


class RequestTimeout(GenomixError, TimeoutError):
    """A blocking call did not end within its timeout.

    The request itself keeps running on the component: wait for it again, or abort it.

    Attributes:
        request: The request handle (None when the send itself timed out).
    """

    def __init__(self, message: str, request: Any = None) -> None:
        super().__init__(message)
        self.request = request


class ProtocolError(GenomixError):
    """A reply that does not follow the wire contract (docs/protocol.md)."""


class ModuleUnloaded(GenomixError):
    """The module of a pending request was unloaded before the request reported its end."""


class ClientClosed(GenomixError):
    """The client was closed, or its session was stopped by someone else (``quit`` event)."""


# Fixed classes for the ids every gateway may send; declared ids get generated classes.
_WELL_KNOWN: dict[str, type[RemoteError]] = {
    "::genom::interrupted": Interrupted,
    "::genom::serialization": InvalidInput,
    "::genomix::bad_load": InvalidInput,
    "::genomix::no_such_module": NotFound,
    "::genom::no_such_service": NotFound,
    "::genom::no_such_outport": NotFound,
    "::genom::no_such_inport": NotFound,
    "::genomix::no_such_request": NotFound,
    "::genomix::no_such_session": NotFound,
    "::genomix::forbidden": Forbidden,
    "::genomix::unauthorized": Forbidden,
    "::genom::too_many_activities": TooManyActivities,
    "::genom::remote_io": HostUnreachable,
}

_generated: dict[str, type[RemoteError]] = {}
_generated_lock = threading.Lock()


def short_name(ex: str) -> str:
    """``::demo::TOO_FAR_AWAY`` -> ``TOO_FAR_AWAY``."""
    return ex.rpartition("::")[2] or ex


def remote_exception_class(ex: str, doc: str | None = None,
                           detail: Sequence[Mapping[str, Any]] = ()) -> type[RemoteError]:
    """The class raised for exception id *ex*, generated on first use.

    Classes are shared by the whole process, so ``except demo.TOO_FAR_AWAY``
    catches the exception whichever client, instance or generated file raised it.

    Args:
        ex: The full exception id (``::demo::TOO_FAR_AWAY``).
        doc: Its documentation from ``/info`` (used when the class is created).
        detail: Its members from ``/info`` (listed in the class docstring).

    Returns:
        A subclass of :class:`RemoteError` (a fixed one for the standard genom ids).
    """
    known = _WELL_KNOWN.get(ex)
    if known is not None:
        return known
    with _generated_lock:
        cls = _generated.get(ex)
        if cls is None:
            text = (doc or f"The genom exception {ex}.").strip()
            if detail:
                members = "\n".join(f"    {m['name']} ({m['type']['name']})" for m in detail)
                text += f"\n\nDetail members (also attributes):\n{members}"
            text += f"\n\nException id: ``{ex}``."
            cls = type(short_name(ex), (RemoteError,), {
                "ex": ex, "__doc__": text, "__module__": "aiogenomix.clients.remote",
                "__qualname__": short_name(ex),
            })
            _generated[ex] = cls
        return cls


def remote_error(body: Mapping[str, Any], *, request_id: str | None = None, module: str | None = None,
                 service: str | None = None) -> RemoteError:
    """Build the exception for an ``{"ex", "detail", "message"}`` object (an error body or a status's exception)."""
    ex = str(body.get("ex", "::genom::unkex"))
    detail = body.get("detail")
    cls = remote_exception_class(ex)
    return cls(ex, detail if isinstance(detail, Mapping) else {}, request_id=request_id, module=module,
               service=service, message=body.get("message"))
