"""The exception tree of the component runtime, and the standard genom3 exceptions.

::

    ComponentError                       anything the runtime refuses
    ├── InputError (ValueError)          input JSON that does not fit the declared types
    ├── NoSuchModule (LookupError)       unknown component instance or component name
    ├── NoSuchService (LookupError)      unknown service of a component
    ├── NoSuchPort (LookupError)         unknown port, or unknown element of a multiple port
    ├── NoSuchRequest (LookupError)      unknown request id
    ├── RequestRunning                   ``clean`` of a request that has not ended
    ├── PortUnavailable                  a read of a port whose data is withdrawn (its sensor is down)
    ├── AmbiguousModule (LookupError)    a name that several component hosts offer: say which
    ├── RemoteUnreachable                an instance of another process did not answer, or is not heard from
    │   └── RemoteHostGone               an instance of another process whose host is gone (it may come back)
    ├── RemoteRefusal                    an instance of another process refused: its error, as answered there
    └── GenomException                   an exception in the genom3 sense, with an id and a detail
        ├── (declared by components, e.g. ::demo::TOO_FAR_AWAY)
        └── the standard ::genom::* exceptions (interrupted, too_many_activities, ...)

A :class:`GenomException` raised by a service ends its request in ``error`` with
``{"ex": "::comp::NAME", "detail": {...}}``.  Its annotated class attributes are
its detail members, in declaration order.
"""

from __future__ import annotations

import difflib
import typing
from collections.abc import Collection
from typing import Any, ClassVar

__all__ = [
    "ComponentError", "InputError", "NoSuchModule", "NoSuchService", "NoSuchPort", "NoSuchRequest",
    "RequestRunning", "PortUnavailable", "AmbiguousModule", "RemoteUnreachable", "RemoteHostGone", "RemoteRefusal",
    "GenomException", "interrupted", "too_many_activities", "unkex", "syserr", "no_such_service", "no_such_outport",
    "no_such_inport", "port_io", "serialization", "disallowed", "no_such_activity", "remote_io", "names_hint",
]

#: Up to this many names are listed whole in a refusal; beyond, the likely ones and where the rest are.
_LISTED = 12


def names_hint(name: str, names: Collection[str], what: str) -> str:
    """What a refusal of the unknown *name* says of the *names* it may have meant: all when few, else the close ones.

    ``(available: demo, kemar)``; with a hundred remote instances, ``(did you mean h01d1 or h01d2? 100 loaded,
    listed by /)``: a refusal does not repeat a hundred names.
    """
    ordered = sorted(names)
    if len(ordered) <= _LISTED:
        return f"({what}: {', '.join(ordered) or 'none'})"
    close = difflib.get_close_matches(name, ordered, n=3)
    guess = f"did you mean {' or '.join(close)}? " if close else ""
    return f"({guess}{len(ordered)} {what}, listed by /)"


class ComponentError(Exception):
    """Base of every error the component runtime reports."""


class InputError(ComponentError, ValueError):
    """Input data that does not fit its declared type.

    Args:
        path: Where in the input the problem is (``posRef``, ``state.position``).
        message: What is wrong, in words a user understands.
    """

    def __init__(self, path: str, message: str) -> None:
        self.path = path
        self.message = message
        super().__init__(f"{path}: {message}" if path else message)


class NoSuchModule(ComponentError, LookupError):
    """No component instance (or loadable component) of that name."""


class NoSuchService(ComponentError, LookupError):
    """The component has no service of that name."""


class NoSuchPort(ComponentError, LookupError):
    """The component has no port (or port element) of that name."""


class NoSuchRequest(ComponentError, LookupError):
    """No request of that id exists (or it was cleaned)."""


class RequestRunning(ComponentError):
    """The request has not ended yet, so it cannot be cleaned."""


class PortUnavailable(ComponentError):
    """A read of an out port whose data its component withdrew: not current, so not served as if it were.

    Attributes:
        port: The port's name.
        reason: The component's exception saying why (``::world::SENSOR_DOWN``...).
    """

    def __init__(self, port: str, reason: GenomException) -> None:
        self.port, self.reason = port, reason
        super().__init__(f"port {port} has no current data: {reason}")


class AmbiguousModule(ComponentError, LookupError):
    """A name that several component hosts offer: the load must say which (``NAME@HOST``)."""


class RemoteUnreachable(ComponentError):
    """An instance of another process did not answer in time, or was not heard from within the bound.

    Its process died, froze, or the network between is cut: answered as ``::genom::remote_io``.
    """


class RemoteHostGone(RemoteUnreachable):
    """An instance that ran in another process whose host is gone: unknown here until that host offers it again.

    Not an unknown name (404): the instance existed and may come back; answered 503 ``::genom::remote_io``
    naming the host and when it was last heard from.

    Args:
        message: What happened, in words.
        host: The id of the host that ran it.
        last_heard: When that host was last heard from (ISO 8601, UTC; None: never).
    """

    def __init__(self, message: str, host: str, last_heard: str | None) -> None:
        super().__init__(message)
        self.host, self.last_heard = host, last_heard


class RemoteRefusal(ComponentError):
    """An instance of another process refused: its genomix error, answered as the host of the instance answers it.

    Args:
        status: The HTTP status of the error.
        body: The genomix error body (``ex``, ``detail``, ``message``).
    """

    def __init__(self, status: int, body: dict[str, Any]) -> None:
        super().__init__(body.get("message", body.get("ex", "")))
        self.status, self.body = status, body


class GenomException(ComponentError):
    """An exception with a genom3 id and structured detail.

    Subclass it to declare a component exception; the annotated attributes
    become the detail members::

        class TOO_FAR_AWAY(GenomException):
            \"\"\"The target is outside the track.\"\"\"
            overshoot: Double

        raise TOO_FAR_AWAY(overshoot=0.25)

    The id is ``::<component>::<class name>`` for the component that raises or
    declares it, unless the class sets :attr:`scope` (``"genom"`` for the
    standard exceptions).
    """

    #: Fixed scope of the id, or None to use the declaring component's name.
    scope: ClassVar[str | None] = None
    #: The component that raised it, once known (names the id of a refusal).
    component: str | None = None
    #: The detail members of each class, found once (in its own ``__dict__``: a subclass has its own).
    _detail_cache: ClassVar[list[tuple[str, Any]]]

    def __init__(self, *args: Any, **detail: Any) -> None:
        names = [name for name, _ in self.detail_members()]
        if len(args) > len(names):
            raise TypeError(f"{type(self).__name__} takes {len(names)} detail values, got {len(args)}")
        values = dict(zip(names, args, strict=False))
        values.update(detail)
        unknown = set(values) - set(names)
        if unknown:
            raise TypeError(f"{type(self).__name__} has no detail member {sorted(unknown)[0]!r}")
        self.detail = {name: values.get(name, typ.zero()) for name, typ in self.detail_members()}
        summary = ", ".join(f"{k}={v!r}" for k, v in self.detail.items())
        super().__init__(f"{type(self).__name__}({summary})" if summary else type(self).__name__)

    @classmethod
    def detail_members(cls) -> list[tuple[str, Any]]:
        """The ``(name, IdlType)`` pairs of the detail, in declaration order."""
        cached = cls.__dict__.get("_detail_cache")
        if cached is None:
            from ._types import idl_type

            hints = {}
            for klass in reversed(cls.__mro__):
                if klass is GenomException or not issubclass(klass, GenomException):
                    continue
                own = typing.get_type_hints(klass, include_extras=True)
                for name in klass.__dict__.get("__annotations__", {}):
                    if typing.get_origin(own[name]) is not ClassVar:
                        hints[name] = idl_type(own[name])
            cached = list(hints.items())
            cls._detail_cache = cached
        return cached

    @classmethod
    def ex_id(cls, component: str) -> str:
        """The genom3 id of this exception when raised by *component*."""
        return f"::{cls.scope or component}::{cls.__name__}"

    @property
    def id(self) -> str:
        """The genom3 id, for the component that raised it."""
        return self.ex_id(self.component or "genomix")

    def encoded_detail(self) -> dict[str, Any] | None:
        """The detail as JSON-ready data (None when the exception has no members)."""
        members = self.detail_members()
        if not members:
            return None
        return {name: typ.encode(self.detail[name]) for name, typ in members}


def _standard(name: str, doc: str, **members: Any) -> type[GenomException]:
    from ._types import String, ULong

    annotations = {key: {"string": String, "ulong": ULong}[value] for key, value in members.items()}
    return type(name, (GenomException,), {"__doc__": doc, "scope": "genom", "__annotations__": annotations})


interrupted = _standard("interrupted", "The request was interrupted by another service.", by="string")
too_many_activities = _standard("too_many_activities", "Too many activities are running in this component.")
unkex = _standard("unkex", "An unexpected error inside a service.", what="string")
syserr = _standard("syserr", "A system error.", code="ulong")
no_such_service = _standard("no_such_service", "No such service.")
no_such_outport = _standard("no_such_outport", "No such out port.")
no_such_inport = _standard("no_such_inport", "No such in port.")
port_io = _standard("port_io", "A port could not be read, written or connected (``what`` says why).", what="string")
serialization = _standard("serialization", "Input data could not be decoded.", what="string")
disallowed = _standard("disallowed", "The service is not allowed now.")
no_such_activity = _standard("no_such_activity", "No activity of that id.")
remote_io = _standard("remote_io", "A component of another process did not answer, or was not heard from "
                      "(``what`` says which and why).", what="string")
