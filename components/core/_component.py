"""The Component base class: declarations collected from the class, and the request engine.

A component class declares services, ports, tasks and exceptions; an instance
runs them: :meth:`Component.send` decodes and validates a request, interrupts
the services it must, and runs it (an activity as its own asyncio task), with
every outcome ending as ``done`` or ``error`` — never a hang.
"""

from __future__ import annotations

import asyncio
import datetime
import inspect
import logging
from collections.abc import Callable
from typing import TYPE_CHECKING, Annotated, Any, ClassVar, TypeVar

from ._exceptions import (
    AmbiguousModule, ComponentError, GenomException, InputError, NoSuchPort, NoSuchRequest, NoSuchService,
    PortUnavailable, RemoteUnreachable, disallowed, interrupted, no_such_activity, no_such_inport,
    no_such_outport, no_such_service, port_io, remote_io, too_many_activities, unkex,
)
from ._log_limits import ThrottledLog
from ._ports import ComputedOutPort, InPort, InPortRuntime, OutPortRuntime, PortSpec
from ._requests import SENDER_SCOPE, Request, RequestTracker
from ._services import ServiceSpec, activity, check_redeclaration, check_validate_hook, function, service_spec
from ._state import GenomState
from ._tasks import Task, TaskRuntime
from ._types import Bound, ULong

if TYPE_CHECKING:
    from ._clock import Clock
    from ._host import ComponentHost
    from ._instance import Placement

__all__ = ["Component"]

T = TypeVar("T")

log = logging.getLogger(__name__)
#: Unexpected failures of services, which clients can set off again and again.
_unexpected = ThrottledLog(log)

_STANDARD_SERVICES = ("abort_activity", "connect_port", "connect_service", "kill")


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

    Args:
        host: The host that runs the instance (clock, settings, peers).
        instance: The instance name (the component name unless loaded with ``-i``).
        argv: Extra load arguments (see :attr:`usage_options`).
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
        # Bases first, so a merged component lists its parts' declarations in order,
        # and the standard services (declared on Component) come last.
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
        for standard in _STANDARD_SERVICES:
            services[standard] = services.pop(standard)
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
        self.requests = RequestTracker(instance, host.announce_request, wall=host.clock.wall)
        self._port_runtimes: dict[str, OutPortRuntime[Any] | InPortRuntime[Any]] = {}
        self._task_runtimes: dict[str, TaskRuntime] = {}
        self._started = False
        self._killed = False

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
        """The ``/module/M/info`` description of the instance (see :func:`describe`)."""
        from ._describe import describe

        return describe(self)

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
        await asyncio.gather(*(self.interrupt(r, by="kill") for r in self.requests.running()))
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

    async def session_ended(self, session: str, sent_by: Callable[[Request], bool] | None = None) -> None:
        """The host's seam: *session* ended; hand its running requests (those *sent_by* one gateway) to the hook."""
        requests = [r for r in self.requests.running()
                    if r.session == session and (sent_by is None or sent_by(r))]
        if requests:
            await self.on_session_end(session, requests)

    # -- requests -------------------------------------------------------------------------

    def service(self, name: str) -> ServiceSpec:
        """The spec of a service.

        Raises:
            NoSuchService: when there is none of that name.
        """
        try:
            return self._services[name]
        except KeyError:
            raise NoSuchService(
                f"{self.instance} has no service {name!r} (services: {', '.join(self._services)})"
            ) from None

    def decode_inputs(self, spec: ServiceSpec, raw: Any) -> dict[str, Any]:
        """Decode request inputs; inputs not given take the host-dependent defaults first."""
        if raw is None and not spec.inputs:
            # A service without parameters sent without input (most sends): nothing to decode or default.
            return {}
        return spec.decode_inputs(raw, self.service_defaults(self.host).get(spec.name))

    async def send(self, name: str, raw_input: Any = None, *, session: str | None = None,
                   oneway: bool = False) -> Request:
        """Start a request of service *name* with the JSON-decoded *raw_input*.

        As in genom3, ``validate`` runs inside the component once the request is
        sent: a refusal is a request that ends in ``error`` with the declared
        exception, reported like any other end.  Only what genom3 refuses before
        sending anything raises here.

        Returns:
            The request: running (an activity), or possibly ended (a function, or a
            request refused by ``validate``).

        Raises:
            NoSuchService, InputError: for a bad request (nothing is started).
            GenomException: ``too_many_activities``, or ``disallowed`` once the
                component was killed (no request is created).
        """
        spec = self.service(name)
        inputs = self.decode_inputs(spec, raw_input)
        # Checked before validate too: a killed component's validate may touch closed hardware.
        self._refuse_if_killed()
        refusal = await self._validate(spec, inputs)
        # From here to the creation of its task nothing awaits: a concurrent send sees
        # all of this admission or none of it, so interruption is decided atomically.
        self._admit(spec)
        request = self.requests.create(spec, inputs, session, oneway)
        if refusal is not None:
            self._settle_error(request, refusal)
            return request
        # Only a service that interrupts others looks at the running requests (most interrupt none).
        victims = [r for r in self.requests.running()
                   if r is not request and r.service.name in spec.interrupts] if spec.interrupts else []
        for victim in victims:
            self._signal_interrupt(victim, by=spec.name)
        if not victims and spec.kind != "activity" and not spec.is_async:
            # A plain function or attribute runs to its end right here: no task to schedule.
            try:
                result = spec.func(self, **inputs)
            except Exception as exc:
                self._settle_error(request, exc)
            else:
                self._settle(request, result)
        else:
            # The task first waits for the victims' stop paths: a request that is itself
            # interrupted meanwhile is cancelled there and never runs its service.
            request.task = asyncio.create_task(self._run(request, victims), name=request.id)
            request.task.add_done_callback(lambda _: self._end_unstarted(request))
            try:
                if victims:
                    # The reply (and the "sent" event) come after the victims' ends, as in genom3.
                    await self._wait_stopped(victims)
                if spec.kind != "activity":
                    # Functions and attributes are quick: let them end before the reply is sent.
                    await asyncio.wait({request.task}, timeout=self.host.function_grace)
            finally:
                # Even when the sender gave up waiting: the request runs, its session hears of it.
                if request.running:
                    self.requests.announce(request)
        self.genom_state.changed()
        return request

    def _refuse_if_killed(self) -> None:
        if self._killed:
            exc = disallowed()
            exc.component = self.genom_name
            raise exc

    def _admit(self, spec: ServiceSpec) -> None:
        """Raise what refuses a request before it exists: a killed component, too many activities."""
        self._refuse_if_killed()
        if spec.kind == "activity" and sum(
            r.service.kind == "activity" for r in self.requests.running()
        ) >= self.max_activities:
            exc = too_many_activities()
            exc.component = self.genom_name
            raise exc

    async def _validate(self, spec: ServiceSpec, inputs: dict[str, Any]) -> Exception | None:
        """Run the service's ``validate`` hook; return what it raised (None: accepted)."""
        if spec.validate is None:
            return None
        try:
            verdict = spec.validate(self, **inputs)
            if inspect.isawaitable(verdict):
                await verdict
        except Exception as exc:
            return exc
        return None

    async def _run(self, request: Request, victims: list[Request]) -> None:
        try:
            if victims:
                await self._wait_stopped(victims)
            result = request.service.func(self, **request.inputs)
            if inspect.isawaitable(result):
                result = await result
        except asyncio.CancelledError:
            if request.interrupted_by is None:
                raise
            self._end_error(request, interrupted(by=request.interrupted_by))
        except Exception as exc:
            self._settle_error(request, exc)
        else:
            self._settle(request, result)
        finally:
            if request.running:  # cancelled by the event loop shutting down
                self._end_error(request, interrupted(by="kill"))
            self.genom_state.changed()

    def _settle(self, request: Request, result: Any) -> None:
        """End a request whose service returned *result*."""
        if request.interrupted_by is not None:
            self._end_error(request, interrupted(by=request.interrupted_by))
            return
        try:
            output = request.service.encode_outputs(result)
        except Exception as exc:
            self._settle_error(request, exc)
        else:
            self.requests.finish(request, "done", output=output)

    def _settle_error(self, request: Request, exc: Exception) -> None:
        """End a request whose service raised *exc*."""
        if isinstance(exc, PortUnavailable):
            exc = exc.reason  # an in port read while its out port's data is withdrawn: the reason why
        if not isinstance(exc, GenomException):
            # A fault of the component, not of the client; still a client may trigger it again and
            # again: one traceback per place it comes from, then rate-limited lines.
            _unexpected.error("%s: service %s failed: %s", self.instance, request.service.name,
                              f"{type(exc).__name__}: {exc}", exc=exc)
            exc = unkex(what=f"{type(exc).__name__}: {exc}")
        self._end_error(request, exc)

    def _end_error(self, request: Request, exc: GenomException) -> None:
        self.requests.finish(request, "error", exception=self.exception_object(exc))

    def exception_object(self, exc: GenomException) -> dict[str, Any]:
        """The ``{"ex": ..., "detail": ...}`` object of an exception raised here."""
        obj: dict[str, Any] = {"ex": type(exc).ex_id(self.genom_name)}
        detail = exc.encoded_detail()
        if detail is not None:
            obj["detail"] = detail
        return obj

    def _signal_interrupt(self, request: Request, by: str) -> None:
        """Tell a running request to stop, at once and without waiting.

        Only the first interrupter counts: cancelling a task again would cut
        its stop path short (the robot would be left moving).
        """
        if not request.running or request.interrupted_by is not None:
            return
        request.interrupted_by = by
        if request.task is None:
            # Only an inline function has no task, and it never waits: kept so that no request is skipped.
            self._end_unstarted(request)
        else:
            request.task.cancel(f"interrupted by {by}")

    def _end_unstarted(self, request: Request) -> None:
        """End a request whose task ended without ending it (cancelled before its first step)."""
        if request.running and (request.task is None or request.task.done()):
            self._end_error(request, interrupted(by=request.interrupted_by or "kill"))
            self.genom_state.changed()

    async def _wait_stopped(self, requests: list[Request]) -> None:
        """Wait until every one of *requests* has ended (their stop paths have run)."""
        tasks = {r.task for r in requests if r.task is not None and not r.task.done()}
        if tasks:
            # asyncio.wait never cancels what it waits for: a cancelled waiter leaves the victims stopping.
            await asyncio.wait(tasks)
        for request in requests:
            self._end_unstarted(request)

    async def interrupt(self, request: Request, by: str) -> None:
        """Interrupt a running request and wait for its stop path to finish."""
        self._signal_interrupt(request, by)
        await self._wait_stopped([request])

    async def abort(self, request_id: str) -> Request:
        """Interrupt the request *request_id* (``by: "abort"``) and return it."""
        request = self.requests.get(request_id)
        await self.interrupt(request, by="abort")
        return request

    async def request(self, request_id: str) -> Request:
        """The request *request_id* (awaitable: a proxy of a remote component may have to ask for it).

        Raises:
            NoSuchRequest: when there is none.
        """
        return self.requests.get(request_id)

    async def clean(self, request_id: str) -> None:
        """Forget the ended request *request_id*, freeing its id.

        Raises:
            NoSuchRequest: when there is none.
            RequestRunning: when it has not ended.
        """
        self.requests.clean(request_id)

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

    # -- the standard services of every genom3 component -------------------------------------

    @function(throws=(no_such_activity,))
    async def abort_activity(self, activity: ULong) -> None:
        """Abort the running activity of request number ``activity`` (one that has ended: nothing to do).

        A number that names no request of an activity (none at all, or a function's, this one's
        included) ends in ``::genom::no_such_activity``.
        """
        try:
            request = self.requests.get(activity)
        except NoSuchRequest:
            raise no_such_activity() from None
        scope = SENDER_SCOPE.get()
        if request.service.kind != "activity" or (scope is not None and not scope(request)):
            # Another gateway's request (SENDER_SCOPE): as unknown to this sender as a free number.
            raise no_such_activity()
        if request.running:
            await self.interrupt(request, by="abort_activity")

    @function(throws=(no_such_inport, no_such_outport, port_io, remote_io))
    async def connect_port(self, local: Annotated[str, Bound(128)], remote: Annotated[str, Bound(128)]) -> None:
        """Connect the in port ``local`` to the out port ``remote`` ("component/port[/element]").

        The out port must publish the in port's type (``port_io`` names both types otherwise, and
        the in ports of this component that read the out port's type). It may belong to a
        component of another process when the host finds remote components
        (``aiogenomix-component --zenoh-...``): ``remote_io`` when its host does not answer,
        ``port_io`` saying why for any other refusal (two hosts offer the name: ``NAME@HOST``).
        """
        spec = self._ports.get(local)
        if spec is None or spec.direction != "in":
            raise no_such_inport()
        parts = remote.strip("/").split("/", 2)
        if len(parts) < 2:
            raise no_such_outport()
        try:
            peer = await self.host.peer(parts[0])
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
            fitting = [name for name, other in self._ports.items()
                       if isinstance(other, InPort) and other.reads(target.type)]
            hint = f"; {', '.join(fitting)} of {self.instance} reads it" if fitting else ""
            raise port_io(what=f"{self.instance}/{local} reads {spec.what_it_reads()}, {remote.strip('/')} "
                               f"publishes {target.type.name}{hint}")
        self.in_port(local).connect(target, remote, parts[2] if len(parts) > 2 else None)

    @function(throws=(no_such_service,))
    def connect_service(self, local: Annotated[str, Bound(128)], remote: Annotated[str, Bound(128)]) -> None:
        """Connect a used service to a remote one (no component here uses remote services)."""
        raise no_such_service()

    @activity
    async def kill(self) -> None:
        """Stop the component: interrupt every activity and unload it."""
        self._killed = True
        me = asyncio.current_task()
        await asyncio.gather(*(self.interrupt(r, by="kill") for r in self.requests.running()
                               if r.task is not me))
        self.host.unload_soon(self.instance)
