"""The reply bodies of whole reads of chunked ports (the audio window): one per publication and form, made ahead.

A client polling the audio window at its publication rate reads each
publication once, a little while after it was published.  Making that read's
body (the small struct around the chunks' pre-encoded pieces) when the read
comes cost the read about 50 µs when warm, and about 340 µs of a 1 ms
read after the pause between two polls (the port-read benchmark's "each read a
new publication").  So a body is kept per publication and form (JSON or
binary, and the element of a multiple port): every reader of a publication
shares it.  And for each form read during a publication, one task per polled
port makes the next publication's body as soon as it is published, so that the
next poll finds it ready.  A form nobody read during a publication is not made
for the next one, and the task of a port nobody reads ends after
:data:`IDLE_PUBLICATIONS` publications, letting go of the port's bodies: a JSON
body of the audio window holds its publication's chunks and their texts (about
3x the window's bytes, 150 MB for a 59 MiB window), which would otherwise stay
long after the port has moved on and nobody reads it.
"""

from __future__ import annotations

import asyncio
import logging
import weakref
from collections.abc import Callable
from typing import Any

from ..components.core import OutPortRuntime
from ._pieces import PiecesPayload
from ._unloads import Unloads

__all__ = ["ReadBodies", "IDLE_PUBLICATIONS"]

log = logging.getLogger(__name__)

#: Publications a polled port's task waits through with no read before it ends.
IDLE_PUBLICATIONS = 20

Body = bytes | PiecesPayload
#: A read's form: binary or not, and the element of a multiple port (None for a single port).
Form = tuple[bool, str | None]
#: Makes the body of a port's data: ``make(port, value)``.  Given the port, not holding it: the kept
#: bodies are weakly keyed by their port, which a value referring to it would keep alive.
Make = Callable[[OutPortRuntime[Any], Any], Body]


class _Port:
    """What is kept of one port: the last body of each form, and the forms read during this publication."""

    __slots__ = ("bodies", "read", "task")

    def __init__(self) -> None:
        self.bodies: dict[Form, tuple[Any, Body, Make]] = {}
        self.read: set[Form] = set()
        self.task: asyncio.Task[None] | None = None


class ReadBodies:
    """The bodies of whole reads of chunked ports, per publication and form (see the module's description).

    Held by the application: two gateways in one process never share bodies.

    Args:
        unloads: The end of each instance (a port's task ends with its instance).
        stopping: A future done when the gateway shuts down (the tasks end then).
    """

    def __init__(self, unloads: Unloads, stopping: Callable[[], asyncio.Future[None]]) -> None:
        self._unloads = unloads
        self._stopping = stopping
        self._ports: weakref.WeakKeyDictionary[OutPortRuntime[Any], _Port] = weakref.WeakKeyDictionary()

    def body(self, port: OutPortRuntime[Any], value: Any, form: Form, make: Make) -> Body:
        """The body of a whole read of *port*'s publication *value* in *form*, made by ``make(port, value)`` once."""
        kept = self._ports.get(port)
        if kept is None:
            kept = self._ports[port] = _Port()
        kept.read.add(form)
        if kept.task is None:
            # The next publication as of now: one made before the task first runs is not missed.
            kept.task = asyncio.get_running_loop().create_task(self._prepare(port, kept, port.next_publication()),
                                                               name=f"read bodies of {port.name}")
        found = kept.bodies.get(form)
        if found is not None and found[0] is value:
            return found[1]
        body = make(port, value)
        kept.bodies[form] = (value, body, make)
        return body

    async def _prepare(self, port: OutPortRuntime[Any], kept: _Port, publication: asyncio.Future[None]) -> None:
        """Make each publication's body of the forms read during the one before, until nobody reads; then let go."""
        ended = {self._unloads.of(port.owner), self._stopping()}
        idle = 0
        try:
            while idle < IDLE_PUBLICATIONS:
                await asyncio.wait({publication, *ended}, return_when=asyncio.FIRST_COMPLETED)
                publication = port.next_publication()
                if any(future.done() for future in ended):
                    return
                wanted, kept.read = kept.read, set()
                idle = 0 if wanted else idle + 1
                for form in wanted:
                    self._make_ahead(port, kept, form)
        finally:
            kept.task = None
            kept.bodies.clear()  # nobody reads (or the port is gone): the next read makes its body

    @staticmethod
    def _make_ahead(port: OutPortRuntime[Any], kept: _Port, form: Form) -> None:
        found = kept.bodies.get(form)
        if found is None:  # its last read failed to make it: the next read will say why
            return
        make = found[2]
        try:
            value = port.read(form[1])
            kept.bodies[form] = (value, make(port, value), make)
        except Exception as exc:  # noqa: BLE001  # the read itself will meet it, and answer it
            log.debug("%s: no body made ahead for %s: %s", port.name, form, exc)
            del kept.bodies[form]
