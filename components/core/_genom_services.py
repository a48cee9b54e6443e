"""The services every genom3 component has: ``abort_activity``, ``connect_port``, ``connect_service``, ``kill``.

A component's author declares none of them: :class:`GenomServices` declares and
implements them once, with the same decorators as an author's services, and every
component's service table ends with them (``/info`` lists them last, as genom3
does).  Each takes the component it serves, as an author's service takes
``self``: the request engine runs them like any other service, and they reach the
instance's requests through its engine and its ports and peers through the
component.

A merged component may redeclare one as it redeclares a service of its parts
(``binauloc`` says which audio ports its ``connect_port`` takes)::

    @redeclare(GenomServices.connect_port, doc="Connect Audio to any audio port ...")
    async def connect_port(self, **inputs: Any) -> None:
        await GenomServices.connect_port(self, **inputs)
"""

from __future__ import annotations

import asyncio
from typing import TYPE_CHECKING, Annotated, TypeVar

from ._exceptions import (
    AmbiguousModule, ComponentError, InputError, NoSuchRequest, RemoteUnreachable, no_such_activity,
    no_such_inport, no_such_outport, no_such_service, port_io, remote_io,
)
from ._ports import InPort, OutPortRuntime
from ._requests import SENDER_SCOPE
from ._services import ServiceSpec, activity, function, service_spec
from ._types import Bound, ULong

if TYPE_CHECKING:
    from ._component import Component

__all__ = ["GenomServices", "GENOM_SERVICES"]

#: The component a standard service serves: any component (a redeclaration keeps its own class).
_C = TypeVar("_C", bound="Component")


class GenomServices:
    """The genom3 standard services, run by every component's engine: each takes the component it serves."""

    @staticmethod
    @function(throws=(no_such_activity,))
    async def abort_activity(component: _C, activity: ULong) -> None:
        """Abort the running activity of request number ``activity`` (one that has ended: nothing to do).

        A number that names no request of an activity (none at all, or a function's, this one's
        included) ends in ``::genom::no_such_activity``.
        """
        try:
            request = component.requests.get(activity)
        except NoSuchRequest:
            raise no_such_activity() from None
        scope = SENDER_SCOPE.get()
        if request.service.kind != "activity" or (scope is not None and not scope(request)):
            # Another gateway's request (SENDER_SCOPE): as unknown to this sender as a free number.
            raise no_such_activity()
        if request.running:
            await component.engine.interrupt(request, by="abort_activity")

    @staticmethod
    @function(throws=(no_such_inport, no_such_outport, port_io, remote_io))
    async def connect_port(component: _C, local: Annotated[str, Bound(128)],
                           remote: Annotated[str, Bound(128)]) -> None:
        """Connect the in port ``local`` to the out port ``remote`` ("component/port[/element]").

        The out port must publish the in port's type (``port_io`` names both types otherwise, and
        the in ports of this component that read the out port's type). It may belong to a
        component of another process when the host finds remote components
        (``aiogenomix-component --zenoh-...``): ``remote_io`` when its host does not answer,
        ``port_io`` saying why for any other refusal (two hosts offer the name: ``NAME@HOST``).
        """
        ports = type(component).ports()
        spec = ports.get(local)
        if spec is None or spec.direction != "in":
            raise no_such_inport()
        parts = remote.strip("/").split("/", 2)
        if len(parts) < 2:
            raise no_such_outport()
        try:
            peer = await component.host.peer(parts[0])
            target = peer.port(parts[1])
        except AmbiguousModule as exc:  # a LookupError, but its message says how to name one
            raise port_io(what=str(exc)) from None
        except (LookupError, InputError):
            raise no_such_outport() from None
        except RemoteUnreachable as exc:
            raise remote_io(what=str(exc)) from None
        except ComponentError as exc:  # the finder's refusals: a host of another protocol, no room, a name taken
            raise port_io(what=str(exc)) from None
        if not isinstance(target, OutPortRuntime):
            raise no_such_outport()
        assert isinstance(spec, InPort)
        if not spec.reads(target.type):
            # Connected anyway, the reader would take one struct for another: refuse, and say what fits.
            fitting = [name for name, other in ports.items() if isinstance(other, InPort) and other.reads(target.type)]
            hint = f"; {', '.join(fitting)} of {component.instance} reads it" if fitting else ""
            raise port_io(what=f"{component.instance}/{local} reads {spec.what_it_reads()}, {remote.strip('/')} "
                               f"publishes {target.type.name}{hint}")
        component.in_port(local).connect(target, remote, parts[2] if len(parts) > 2 else None)

    @staticmethod
    @function(throws=(no_such_service,))
    def connect_service(component: _C, local: Annotated[str, Bound(128)], remote: Annotated[str, Bound(128)]) -> None:
        """Connect a used service to a remote one (no component here uses remote services)."""
        raise no_such_service()

    @staticmethod
    @activity
    async def kill(component: _C) -> None:
        """Stop the component: interrupt every activity and unload it."""
        engine = component.engine
        engine.killed = True
        me = asyncio.current_task()
        await asyncio.gather(*(engine.interrupt(r, by="kill") for r in engine.requests.running() if r.task is not me))
        component.host.unload_soon(component.instance)


def _specs() -> dict[str, ServiceSpec]:
    specs: dict[str, ServiceSpec] = {}
    for name in ("abort_activity", "connect_port", "connect_service", "kill"):
        spec = service_spec(getattr(GenomServices, name))
        assert spec is not None  # each is declared above
        specs[name] = spec
    return specs


#: The standard services' declarations, in the order ``/info`` lists them (after a component's own).
GENOM_SERVICES: dict[str, ServiceSpec] = _specs()
