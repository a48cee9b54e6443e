"""The Component base class: what a component's author writes, and the declarations collected from it.

A component class declares services, ports, tasks and exceptions, and implements
them; an instance holds its ports' data and runs its tasks and hooks.  Its
requests are run by its :class:`~aiogenomix.components.core.runtime.RequestEngine`
(``component.engine``), and the genom3 standard services every component has by
:class:`~aiogenomix.components.core.GenomServices`: an author writes neither.
"""

from __future__ import annotations

import datetime
from collections.abc import Callable, Coroutine
from typing import TYPE_CHECKING, Any, ClassVar, Protocol, TypeVar

from ._engine import RequestEngine
from ._exceptions import GenomException, NoSuchPort
from ._genom_services import GENOM_SERVICES
from ._ports import ComputedOutPort, InPortRuntime, OutPortRuntime, PortSpec
from ._requests import Request, RequestTracker
from ._services import ServiceSpec, check_redeclaration, check_validate_hook, service_spec
from ._state import GenomState
from ._tasks import Task, TaskRuntime

if TYPE_CHECKING:
    from ._clock import Clock
    from ._host import ComponentHost
    from ._instance import Placement

__all__ = ["Component"]

T = TypeVar("T")


class SendRequest(Protocol):
    """Start a request of service *name* with the JSON-decoded *raw_input* (see :meth:`RequestEngine.send`)."""

    def __call__(self, name: str, raw_input: Any = None, *, session: str | None = None,
                 oneway: bool = False) -> Coroutine[Any, Any, Request]:
        """Start the request; the coroutine returns it, running or ended."""
        ...


def _check_progress(spec: ServiceSpec, ports: dict[str, PortSpec], owner: str) -> None:
    """Check that a service's ``progress`` names an out port of the component and a member of its type.

    Raises:
        TypeError: naming the component, the service and what is missing.
    """
    assert spec.progress is not None
    port_name, *path = spec.progress.split(".")
    port = ports.get(port_name)
    if port is None or port.direction != "out":
        outs = ", ".join(name for name, p in ports.items() if p.direction == "out")
        raise TypeError(f"{owner}, service {spec.name}: progress={spec.progress!r} names no out port "
                        f"(out ports: {outs})")
    described = port.type.describe()
    for name in path:
        members = {m["name"]: m["type"] for m in described.get("members", [])}
        if name not in members:
            raise TypeError(f"{owner}, service {spec.name}: progress={spec.progress!r}: {described['name']} has no "
                            f"member {name!r} (members: {', '.join(members) or 'none'})")
        described = members[name]


class Component:
    """Base class of every component.

    Subclass with ``class Demo(Component, name="demo", version="1.1")``.  The
    class docstring documents the component in ``/info``.

    An author writes declarations, service methods and hooks; the instance's
    :class:`~aiogenomix.components.core.runtime.RequestEngine` runs its requests,
    and the host and its scripts drive it through the engine's methods, which the
    instance shows as its own (``send``, ``interrupt``, ``abort``...).

    Args:
        host: The host that runs the instance (clock, settings, peers).
        instance: The instance name (the component name unless loaded with ``-i``).
        argv: Extra load arguments (see :attr:`usage_options`).

    Attributes:
        engine: What runs the instance's requests.
        requests: Its requests, running and ended (the engine's): ``self.requests.running()``.
        send: Start a request: ``await component.send("Point", {"pan": 20})`` (the engine's
            :meth:`~aiogenomix.components.core.runtime.RequestEngine.send`).
    """

    #: The genom3 component name (ids of its exceptions are ``::<name>::X``).
    genom_name: ClassVar[str] = "component"
    version: ClassVar[str] = "1.0"
    #: Load options as ``(option, description)`` pairs, shown by ``/usage``.
    usage_options: ClassVar[list[tuple[str, str]]] = [("-i NAME", "load the component under instance name NAME")]
    #: Exceptions declared without being thrown by a particular service.
    exceptions: ClassVar[tuple[type[GenomException], ...]] = ()
    #: How many activities may run at once before sends fail with too_many_activities.
    max_activities: ClassVar[int] = 32

    _services: ClassVar[dict[str, ServiceSpec]]
    _ports: ClassVar[dict[str, PortSpec]]
    _tasks: ClassVar[dict[str, Task]]

    genom_state = ComputedOutPort(GenomState, compute="_genom_state",
                                  doc="The state of the component's tasks and activities")

    def __init_subclass__(cls, name: str | None = None, version: str | None = None, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if name is not None:
            cls.genom_name = name
        if version is not None:
            cls.version = version
        services: dict[str, ServiceSpec] = {}
        ports: dict[str, PortSpec] = {}
        tasks: dict[str, Task] = {}
        owner = f"component {cls.genom_name!r} ({cls.__name__})"
        # Bases first, so a merged component lists its parts' declarations in order; the standard
        # services (GenomServices', or a component's redeclaration of one) come last.
        for klass in reversed(cls.__mro__):
            for value in vars(klass).values():
                if isinstance(value, PortSpec):
                    ports[value.name] = value
                elif isinstance(value, Task):
                    tasks[value.name] = value
                elif getattr(value, "__genom_service__", None) is not None:
                    try:
                        spec = service_spec(value)
                    except TypeError as exc:
                        # Named like the ports' refusals: the user sees which class and which service.
                        raise TypeError(f"{owner}, service {getattr(value, '__name__', value)}: {exc}") from None
                    assert spec is not None
                    services.pop(spec.name, None)
                    services[spec.name] = spec
        for standard, spec in GENOM_SERVICES.items():
            services[standard] = services.pop(standard, spec)
        ports["genom_state"] = ports.pop("genom_state")
        cls._services, cls._ports, cls._tasks = services, ports, tasks
        for port in ports.values():
            try:
                port.type  # noqa: B018 -- resolved now: a port of no IDL type is refused with its class
            except TypeError as exc:
                raise TypeError(f"{owner}, port {port.name}: {exc}") from None
        for spec in services.values():
            check_redeclaration(spec, owner)
            for target in spec.interrupts:
                if target not in services:
                    raise TypeError(f"{cls.__name__}.{spec.name} interrupts unknown service {target!r}")
            if spec.validate is not None:
                # Caught here rather than as an error at the first request of the service.
                check_validate_hook(spec, owner)
            if spec.progress is not None:
                _check_progress(spec, ports, owner)

    def __init__(self, host: ComponentHost, instance: str, argv: list[str] | None = None) -> None:
        self.host = host
        self.instance = instance
        self.argv = list(argv or [])
        self._port_runtimes: dict[str, OutPortRuntime[Any] | InPortRuntime[Any]] = {}
        self._task_runtimes: dict[str, TaskRuntime] = {}
        self._started = False
        self._description: dict[str, Any] | None = None
        self.engine = RequestEngine(self)
        self.requests: RequestTracker = self.engine.requests
        # The engine's own method rather than a method that calls it: a send reaches the engine
        # in as many steps as when the component ran its requests itself.
        self.send: SendRequest = self.engine.send

    # -- declarations ---------------------------------------------------------------------

    @classmethod
    def services(cls) -> dict[str, ServiceSpec]:
        """The services, in declaration order (standard services last)."""
        return cls._services

    @classmethod
    def ports(cls) -> dict[str, PortSpec]:
        """The port declarations, in declaration order."""
        return cls._ports

    @classmethod
    def tasks(cls) -> dict[str, Task]:
        """The task declarations."""
        return cls._tasks

    @classmethod
    def declared_exceptions(cls) -> list[type[GenomException]]:
        """Every exception the component may raise, declared or thrown by a service."""
        seen: dict[type[GenomException], None] = dict.fromkeys(cls.exceptions)
        for spec in cls._services.values():
            seen.update(dict.fromkeys(spec.throws))
        return list(seen)

    @classmethod
    def service_defaults(cls, host: ComponentHost) -> dict[str, dict[str, Any]]:
        """Per-service input defaults that depend on the host (override to use settings).

        Returns:
            ``{service: {parameter: default}}``; shown in ``/info`` and used for
            missing inputs.
        """
        return {}

    # -- runtime accessors ----------------------------------------------------------------

    @property
    def clock(self) -> Clock:
        """The host's clock."""
        return self.host.clock

    def _port_runtime(self, name: str) -> OutPortRuntime[Any] | InPortRuntime[Any]:
        runtime = self._port_runtimes.get(name)
        if runtime is None:
            runtime = self._port_runtimes[name] = self._ports[name].runtime(self)
        return runtime

    def _task_runtime(self, name: str) -> TaskRuntime:
        runtime = self._task_runtimes.get(name)
        if runtime is None:
            runtime = self._task_runtimes[name] = TaskRuntime(self._tasks[name], self)
        return runtime

    def description(self) -> dict[str, Any]:
        """The ``/module/M/info`` description of the instance (see :func:`describe`), described once.

        Nothing it says changes while the instance is loaded (its class's services, ports,
        exceptions and tasks, its name, the host's settings its defaults come from), so the
        first call describes it and every call returns that same object: read it, never change
        it in place.
        """
        if self._description is None:
            from ._describe import describe

            self._description = describe(self)
        return self._description

    def placement(self) -> Placement:
        """Where the instance runs: in this process."""
        return {"runs": "here", "component": self.genom_name, "version": self.version}

    def port(self, name: str) -> OutPortRuntime[Any] | InPortRuntime[Any]:
        """The runtime of a port.

        Raises:
            NoSuchPort: when the component has no such port.
        """
        if name not in self._ports:
            raise NoSuchPort(f"{self.instance} has no port {name!r} (ports: {', '.join(self._ports)})")
        return self._port_runtime(name)

    def out_port(self, name: str) -> OutPortRuntime[Any]:
        """The runtime of the out port *name* (one that components publish on).

        Raises:
            NoSuchPort: when the component has no such port, or it is an in port.
        """
        runtime = self.port(name)
        if not isinstance(runtime, OutPortRuntime):
            raise NoSuchPort(f"{self.instance}/{name} is an in port, not an out port")
        return runtime

    def in_port(self, name: str) -> InPortRuntime[Any]:
        """The runtime of the in port *name* (one the component reads another's out port through).

        Raises:
            NoSuchPort: when the component has no such port, or it is an out port.
        """
        runtime = self.port(name)
        if not isinstance(runtime, InPortRuntime):
            raise NoSuchPort(f"{self.instance}/{name} is an out port, not an in port")
        return runtime

    def _genom_state(self) -> GenomState:
        """The data of the ``genom_state`` port, computed when it is read."""
        activities: list[dict[str, Any]] = [{"id": r.number, "name": r.service.name} for r in self.requests.running()
                      if r.service.kind == "activity"]
        tasks = [rt.state() | {"activity": [a for a in activities
                                            if self._services[a["name"]].task == rt.name]}
                 for rt in (self._task_runtime(n) for n in self._tasks)]
        untasked = [a for a in activities if self._services[a["name"]].task not in self._tasks]
        if untasked:
            tasks.append({"name": "", "rusage": {"cycles": 0, "timings": {"last": 0, "max": 0, "avg": 0}},
                          "activity": untasked})
        return GenomState.build(
            tasks, digest=self.genom_name, version=self.version,
            date=datetime.datetime.fromtimestamp(self.clock.wall(), datetime.UTC).isoformat(),
        )

    # -- lifecycle ------------------------------------------------------------------------

    async def start(self) -> None:
        """Start tasks, then run :meth:`on_start`."""
        if self._started:
            return
        self._started = True
        for name in self._tasks:
            self._task_runtime(name).start()
        await self.on_start()

    async def stop(self) -> None:
        """Interrupt every running request, stop tasks, then run :meth:`on_stop` (idempotent)."""
        if not self._started:
            return
        self._started = False
        await self.engine.interrupt_all(by="kill")
        for runtime in self._task_runtimes.values():
            await runtime.stop()
        await self.on_stop()

    def provide(self, kind: type[T], value: T) -> None:
        """Offer *value* as the host's *kind* while this instance is loaded (see :meth:`ComponentHost.provide`)."""
        self.host.provide(kind, value, by=self.instance)

    async def on_start(self) -> None:
        """Hook run when the component starts (open hardware, publish initial data)."""

    async def on_stop(self) -> None:
        """Hook run when the component stops (close hardware)."""

    async def stop_motions(self) -> None:
        """Hook: bring to a stop what the motions set going and left going after their request ended.

        A component host calls it when the gateway that sent the last motion (a service declared
        ``motion=True``) vanished, or unloaded this instance: the dead-man switch.  The running
        motions are interrupted first (their stop paths run); this is for a command that ends
        at once and leaves the robot moving (a speed command: ``morse_kemar``'s ``Rotate``).  By
        default nothing: a component whose motions stop when their request ends needs none.
        """

    async def on_session_end(self, session: str, requests: list[Request]) -> None:
        """Hook: the gateway's session *session* ended while *requests* it sent to this instance ran.

        A session ends when its client stops it (``/session/stop``) or is gone: nobody listened to it
        and no client used it for the gateway's ``--session-idle``; all of a gateway's sessions end
        when the gateway that runs them vanishes.  By default nothing: a request goes on whoever sent
        it, as in genomix.  A component whose work belongs to its client ends it here (the
        recorder stops a recording of that session, unless it was asked to outlive it).
        """

    # -- driving the instance: its engine's, for the host and for scripts ---------------------

    async def interrupt(self, request: Request, by: str) -> None:
        """Interrupt a running request and wait for its stop path to finish (see :meth:`RequestEngine.interrupt`)."""
        await self.engine.interrupt(request, by)

    async def abort(self, request_id: str) -> Request:
        """Interrupt the request *request_id* (``by: "abort"``) and return it (see :meth:`RequestEngine.abort`)."""
        return await self.engine.abort(request_id)

    async def request(self, request_id: str) -> Request:
        """The request *request_id* (see :meth:`RequestEngine.request`).

        Raises:
            NoSuchRequest: when there is none.
        """
        return await self.engine.request(request_id)

    async def clean(self, request_id: str) -> None:
        """Forget the ended request *request_id*, freeing its id (see :meth:`RequestEngine.clean`).

        Raises:
            NoSuchRequest: when there is none.
            RequestRunning: when it has not ended.
        """
        await self.engine.clean(request_id)

    async def session_ended(self, session: str, sent_by: Callable[[Request], bool] | None = None) -> None:
        """The host's seam: *session* ended; its running requests (those *sent_by* one gateway) go to the hook."""
        await self.engine.session_ended(session, sent_by)
