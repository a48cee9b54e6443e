"""Out ports (published data) and in ports (connected to another component's out port).

On the class, ``Mobile = OutPort(State, doc=...)`` declares a port; on an
instance, ``self.Mobile`` is its runtime (:class:`OutPortRuntime`), with
``publish()``, ``read()`` and change notification for watchers and in ports.
The declarations are generic in the data type: a type checker infers
``OutPort[State]`` from ``OutPort(State)`` and refuses ``self.Mobile.publish(3)``.
A port of an ``Annotated`` alias (``OutPort(Double)``) says its Python type in
its annotation: ``Position: OutPort[float] = OutPort(Double)``.
"""

from __future__ import annotations

import asyncio
import builtins
from collections.abc import Callable, Mapping
from typing import Any, Generic, Protocol, Self, TypeVar, cast, overload, runtime_checkable

from ._exceptions import GenomException, NoSuchPort, PortUnavailable, port_io
from ._kinds import PortKind
from ._types import DescribedType, IdlType, idl_type

__all__ = ["OutPort", "ComputedOutPort", "InPort", "OutPortRuntime", "ComputedOutPortRuntime", "InPortRuntime",
           "PortSpec", "Incremental"]

T = TypeVar("T")


@runtime_checkable
class Incremental(Protocol):
    """Port data made of numbered items (audio chunks) that can say what is new.

    Publishing such data on a port lets readers ask for the items after the
    last one they hold (``/read/PORT?since=k`` and ``/watch/PORT``) instead of
    re-reading the whole window, the problem the seed's circular design and
    dedicated socket worked around.
    """

    @property
    def index(self) -> int:
        """The number of the newest item (items are numbered from 1; 0 when empty)."""

    # Optional: ``items_per_publication`` (default 1), how many items a publication adds; a
    # ``watch`` that names no ``since=`` starts with the items of the newest publication.

    def since(self, index: int) -> tuple[Any, int]:
        """The same data holding only the items after *index*, and how many of those were lost.

        Items are lost when the window no longer holds them; an *index* at or
        beyond the newest item gives no items and no loss.
        """


class PortSpec:
    """What is common to the declarations of in and out ports."""

    direction = "out"

    def __init__(self, annotation: object, doc: str = "", multiple: bool = False) -> None:
        self.annotation = annotation
        self.doc = doc
        self.multiple = multiple
        self.name = ""
        self._type: IdlType | None = None

    @property
    def type(self) -> IdlType:
        """The IDL type of the port data (resolved on first use)."""
        if self._type is None:
            self._type = idl_type(self.annotation)
        return self._type

    def __set_name__(self, owner: builtins.type, name: str) -> None:
        self.name = name

    def describe(self) -> dict[str, Any]:
        """The ``/info`` description of this port."""
        return {"name": self.name, "dir": self.direction, "kind": "multiple" if self.multiple else "simple",
                "type": self.type.describe(), "doc": self.doc}

    def runtime(self, owner: Any) -> OutPortRuntime[Any] | InPortRuntime[Any]:
        """Create the runtime of this port for a component instance."""
        raise NotImplementedError  # each kind of port makes its own


class OutPort(PortSpec, Generic[T]):
    """Declare an out port.

    On an instance the attribute is the port's :class:`OutPortRuntime`:
    ``self.Mobile.publish(state)``.

    Args:
        annotation: The type of the data (an @idl_struct, Double, ...).
        doc: What the port publishes.
        multiple: A multiple port holds named elements (read with ``?name=``).
        view: The class of what is published when it is not *annotation* itself but a view that
            encodes as it (a window of audio chunks published as the struct of its chunks):
            ``OutPort(PortData, view=PortView)`` is an ``OutPort[PortView]`` for every type checker.
    """

    direction = "out"

    @overload
    def __init__(self: OutPort[T], annotation: type[T], doc: str = "", multiple: bool = False) -> None: ...
    @overload
    def __init__(self: OutPort[T], annotation: object, doc: str = "", multiple: bool = False, *,
                 view: type[T]) -> None: ...
    @overload
    def __init__(self: OutPort[Any], annotation: object, doc: str = "", multiple: bool = False) -> None: ...
    def __init__(self, annotation: object, doc: str = "", multiple: bool = False, *,
                 view: type | None = None) -> None:
        super().__init__(annotation, doc, multiple)
        #: The class of what is published, when it is a view of the annotation's type (None: that type).
        self.view = view

    @overload
    def __get__(self, instance: None, owner: type) -> Self: ...
    @overload
    def __get__(self, instance: object, owner: type) -> OutPortRuntime[T]: ...
    def __get__(self, instance: Any, owner: type) -> Self | OutPortRuntime[T]:
        if instance is None:
            return self
        runtime: OutPortRuntime[T] = instance._port_runtime(self.name)  # (a Component's: each port's made once)
        return runtime

    def runtime(self, owner: Any) -> OutPortRuntime[T]:
        """Create the runtime of this port for a component instance."""
        return OutPortRuntime(self, owner)

    @staticmethod
    def from_description(described: Mapping[str, Any], origin: str = "described") -> OutPort[Any]:
        """The declaration of an out port known only by its ``/info`` description (a recorded or remote port).

        Its type is the description's (:class:`DescribedType`): data comes JSON-ready and is passed
        on as it is; ``/info`` describes the port as it was described.

        Args:
            described: The port's description: ``name``, ``type``, and optionally ``doc`` and ``kind``.
            origin: Where the description comes from (``recorded``, ``mirrored``): its type's ``kind``.
        """
        port: OutPort[Any] = OutPort(object, str(described.get("doc") or ""), described.get("kind") == "multiple")
        port.name = str(described["name"])
        port._type = DescribedType(dict(described.get("type") or {}), origin)
        return port


class ComputedOutPort(OutPort[T]):
    """An out port whose data is computed by a method when read (cheap to keep up to date).

    Args:
        annotation: The type of the data.
        compute: The name of the component method that returns the data.
        doc: What the port publishes.
    """

    def __init__(self, annotation: type[T], compute: str, doc: str = "") -> None:
        super().__init__(annotation, doc)
        self.compute = compute

    def runtime(self, owner: Any) -> OutPortRuntime[T]:
        """Create the runtime of this port for a component instance."""
        return ComputedOutPortRuntime(self, owner)


class InPort(PortSpec, Generic[T]):
    """Declare an in port, connected at run time with the ``connect_port`` service.

    On an instance the attribute is the port's :class:`InPortRuntime`:
    ``self.Pose.read()``, ``await self.Pose.wait_published()``.

    Args:
        annotation: The type of the data (the out port it connects to must have the same, unless *carrying*).
        doc: What the port reads.
        carrying: A port kind (:class:`~aiogenomix.components.core.AudioStream`...): the port also
            reads any out port whose type carries it, whatever component declares that type (another
            package's audio included); what it reads is then that type's data, read by its kind.

    ``InPort(AudioPortData, carrying=AudioStream)`` reads bass's frames, a capture's chunks, or any
    other component's audio; ``/info`` says so (``"reads": "audio"``).
    """

    direction = "in"

    @overload
    def __init__(self: InPort[T], annotation: type[T], doc: str = "", *,
                 carrying: type[PortKind] | None = None) -> None: ...
    @overload
    def __init__(self: InPort[Any], annotation: object, doc: str = "", *,
                 carrying: type[PortKind] | None = None) -> None: ...
    def __init__(self, annotation: object, doc: str = "", *, carrying: type[PortKind] | None = None) -> None:
        super().__init__(annotation, doc)
        self.carrying = carrying

    def reads(self, published: IdlType) -> bool:
        """Whether this port may be connected to an out port of the type *published*."""
        return published.name == self.type.name or (
            self.carrying is not None and isinstance(published.carries, self.carrying))

    def what_it_reads(self) -> str:
        """What the port reads, as a refusal says it: its type, or its kind (``audio (any type that carries it)``)."""
        if self.carrying is None:
            return self.type.name
        return f"{self.carrying.kind} (any type that carries it)"

    def describe(self) -> dict[str, Any]:
        """The ``/info`` description of this port: with ``reads``, the kind it reads, when it reads one."""
        described = super().describe()
        if self.carrying is not None:
            described["reads"] = self.carrying.kind
        return described

    @overload
    def __get__(self, instance: None, owner: type) -> Self: ...
    @overload
    def __get__(self, instance: object, owner: type) -> InPortRuntime[T]: ...
    def __get__(self, instance: Any, owner: type) -> Self | InPortRuntime[T]:
        if instance is None:
            return self
        runtime: InPortRuntime[T] = instance._port_runtime(self.name)  # (a Component's: each port's made once)
        return runtime

    def runtime(self, owner: Any) -> InPortRuntime[T]:
        """Create the runtime of this port for a component instance."""
        return InPortRuntime(self, owner)


class _PortRuntime:
    """What the runtimes of in and out ports share: their declaration and owner."""

    def __init__(self, spec: PortSpec, owner: Any) -> None:
        self.spec = spec
        self.owner = owner

    @property
    def name(self) -> str:
        """The port name."""
        return self.spec.name

    @property
    def type(self) -> IdlType:
        """The IDL type of the data."""
        return self.spec.type


class OutPortRuntime(_PortRuntime, Generic[T]):
    """The data of one out port of one component instance.

    ``version`` counts publications; :meth:`wait_published` lets a watcher wait
    for the next one without polling.  Publish from the event-loop thread (use
    ``loop.call_soon_threadsafe`` from a hardware thread).
    """

    def __init__(self, spec: PortSpec, owner: Any) -> None:
        super().__init__(spec, owner)
        self.version = 0
        self._elements: dict[str, T] = {}
        # (A multiple port has no one value: its elements are the data.)
        self._value: T = cast(T, None) if spec.multiple else spec.type.zero()
        self._published: asyncio.Future[None] | None = None
        #: Why the data is not current (None: it is): reads raise it until the next publication.
        self.withdrawn: GenomException | None = None

    def publish(self, value: T, name: str | None = None) -> None:
        """Publish *value* (for a multiple port, as element *name*); data withdrawn before is current again."""
        self.withdrawn = None
        if self.spec.multiple:
            if name is None:
                raise ValueError(f"port {self.name} is multiple: publish(value, name=...)")
            self._elements[name] = value
        else:
            self._value = value
        self.changed()

    def changed(self) -> None:
        """Count a new publication and wake the readers waiting for one."""
        self.version += 1
        if self._published is not None and not self._published.done():
            self._published.set_result(None)
        self._published = None

    def withdraw(self, reason: GenomException) -> None:
        """Say that the data is no longer current (its sensor is down): reads fail until the next publication.

        A reader gets :class:`PortUnavailable` carrying *reason* (the gateway answers 503 with
        *reason*'s id and detail; a service reading it through an in port ends with *reason*),
        never the old data as if it were new.  Watchers wait for the next publication.  Those
        waiting for it (:meth:`next_publication`) are woken, with no new version: the ones that
        tell others (a component host's exporter) look at :attr:`withdrawn`.
        """
        self.withdrawn = reason
        if self._published is not None and not self._published.done():
            self._published.set_result(None)
        self._published = None

    def read(self, name: str | None = None) -> T:
        """The latest value (for a multiple port, of element *name*).

        Raises:
            NoSuchPort: for an unknown element.
            port_io: when a multiple port is read without an element name.
            PortUnavailable: when the component withdrew the data (:meth:`withdraw`).
        """
        if self.withdrawn is not None:
            raise PortUnavailable(self.name, self.withdrawn)
        if not self.spec.multiple:
            return self._value
        if name is None:
            raise port_io(what=f"port {self.name} is multiple: name an element ({', '.join(self._elements)})")
        if name not in self._elements:
            raise NoSuchPort(f"port {self.name} has no element {name!r} (elements: {', '.join(self._elements)})")
        return self._elements[name]

    def elements(self) -> list[str]:
        """The element names of a multiple port."""
        return list(self._elements)

    def read_as(self, kind: IdlType, name: str | None = None) -> Any:
        """The latest value as a reader of type *kind* holds it (an in port connected here).

        The data of a port of this process is that value already; a port mirrored
        from another process holds encoded data, which it decodes.
        """
        return self.read(name)

    def encoded(self, name: str | None = None) -> Any:
        """The latest value as JSON-ready data."""
        return self.type.encode(self.read(name))

    def next_publication(self) -> asyncio.Future[None]:
        """A future, shared by every reader, done at the next publication or withdrawal (never cancel it)."""
        if self._published is None:
            self._published = asyncio.get_running_loop().create_future()
        return self._published

    async def wait_published(self, after_version: int | None = None) -> int:
        """Wait until a value newer than *after_version* (default: now) is published; return the version."""
        after = self.version if after_version is None else after_version
        while self.version <= after:
            await asyncio.shield(self.next_publication())
        return self.version


class ComputedOutPortRuntime(OutPortRuntime[T]):
    """The runtime of a :class:`ComputedOutPort`: reads call the component's method."""

    def __init__(self, spec: ComputedOutPort[T], owner: Any) -> None:
        super().__init__(spec, owner)
        self._compute = spec.compute

    def read(self, name: str | None = None) -> T:
        """The data, computed now."""
        compute: Callable[[], T] = getattr(self.owner, self._compute)
        return compute()


class InPortRuntime(_PortRuntime, Generic[T]):
    """The in port of one component instance: reads the out port it is connected to."""

    def __init__(self, spec: InPort[T], owner: Any) -> None:
        super().__init__(spec, owner)
        self.in_spec = spec
        self.remote: OutPortRuntime[T] | None = None
        self.remote_name = ""
        self.element: str | None = None
        # Created on first wait: the runtime may be made outside a running loop.
        self._connected: asyncio.Event | None = None

    @property
    def connected(self) -> bool:
        """Whether the port is connected to an out port."""
        return self.remote is not None

    def connect(self, remote: OutPortRuntime[Any], remote_name: str, element: str | None = None) -> None:
        """Connect to *remote* (whose data type must be the same, or carry the kind the port reads).

        Raises:
            port_io: when the port does not read that type (naming both).
        """
        if not self.in_spec.reads(remote.type):
            raise port_io(what=f"{self.name} reads {self.in_spec.what_it_reads()}, {remote_name} publishes "
                               f"{remote.type.name}")
        self.remote, self.remote_name, self.element = remote, remote_name, element
        if self._connected is not None:
            self._connected.set()

    async def wait_published(self, after_version: int | None = None) -> int:
        """Wait until the connected out port publishes (first waiting for a connection); return its version.

        Args:
            after_version: Wait for a publication newer than this version of the
                connected port (default: the next one).
        """
        while self.remote is None:
            if self._connected is None:
                self._connected = asyncio.Event()
            await self._connected.wait()
        return await self.remote.wait_published(after_version)

    def read(self) -> T | None:
        """The latest data of the connected out port (None while unconnected).

        A port that reads a kind (``carrying=``) and is connected to another type reads that type's
        data (JSON-ready for a port of another process): read it by its kind.

        Raises:
            PortUnavailable: when the out port's component withdrew its data (a service reading
                it ends with the component's reason).
        """
        if self.remote is None:
            return None
        as_type = self.type if self.remote.type.name == self.type.name else self.remote.type
        value: T = self.remote.read_as(as_type, self.element)
        return value

    def encoded(self, name: str | None = None) -> Any:
        """The latest data as JSON-ready data."""
        value = self.read()
        return None if value is None else self.type.encode(value)
