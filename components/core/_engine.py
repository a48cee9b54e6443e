"""The request engine: how the requests of one component instance are admitted, run, interrupted and ended.

A :class:`~aiogenomix.components.core.Component` declares services and
implements them; its :class:`RequestEngine` runs them.  :meth:`RequestEngine.send`
decodes and validates a request, interrupts the services it must, and runs it
(an activity as its own asyncio task), with every outcome ending as ``done`` or
``error``, never a hang.  The engine knows a component only by its declarations
(its class's service table, ``max_activities``, ``service_defaults``), its
service methods and its hooks, so it drives any component, whatever package
declares it, the genom3 standard services
(:class:`~aiogenomix.components.core.GenomServices`) included.
"""

from __future__ import annotations

import asyncio
import inspect
import logging
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from ._exceptions import (
    GenomException, NoSuchService, PortUnavailable, disallowed, interrupted, too_many_activities, unkex,
)
from ._log_limits import ThrottledLog
from ._requests import Request, RequestTracker
from ._services import ServiceSpec

if TYPE_CHECKING:
    from ._component import Component

__all__ = ["RequestEngine"]

log = logging.getLogger(__name__)
#: Unexpected failures of services, which clients can set off again and again.
_unexpected = ThrottledLog(log)


class RequestEngine:
    """Runs the requests of one component instance.

    Args:
        component: The instance whose services it runs (its methods, validate hooks and hooks).

    Attributes:
        component: That instance.
        instance: Its instance name (the prefix of its request ids).
        genom_name: Its component's name (the scope of its exception ids).
        requests: Its requests, running and ended (ids, status, events to the sessions).
        killed: Whether ``kill`` ran: every later send is refused with ``::genom::disallowed``.
    """

    def __init__(self, component: Component) -> None:
        self.component = component
        self.instance = component.instance
        self.genom_name = component.genom_name
        host = self._host = component.host
        self.requests = RequestTracker(component.instance, host.announce_request, wall=host.clock.wall)
        self.killed = False
        self._services = type(component).services()
        # Told of every request that starts or ends: made once here rather than looked up at each.
        self._genom_state = component.genom_state

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
        return spec.decode_inputs(raw, self.component.service_defaults(self._host).get(spec.name))

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
                result = spec.func(self.component, **inputs)
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
                    await asyncio.wait({request.task}, timeout=self._host.function_grace)
            finally:
                # Even when the sender gave up waiting: the request runs, its session hears of it.
                if request.running:
                    self.requests.announce(request)
        self._genom_state.changed()
        return request

    def _refuse_if_killed(self) -> None:
        if self.killed:
            exc = disallowed()
            exc.component = self.genom_name
            raise exc

    def _admit(self, spec: ServiceSpec) -> None:
        """Raise what refuses a request before it exists: a killed component, too many activities."""
        self._refuse_if_killed()
        if spec.kind == "activity" and sum(
            r.service.kind == "activity" for r in self.requests.running()
        ) >= self.component.max_activities:
            exc = too_many_activities()
            exc.component = self.genom_name
            raise exc

    async def _validate(self, spec: ServiceSpec, inputs: dict[str, Any]) -> Exception | None:
        """Run the service's ``validate`` hook; return what it raised (None: accepted)."""
        if spec.validate is None:
            return None
        try:
            verdict = spec.validate(self.component, **inputs)
            if inspect.isawaitable(verdict):
                await verdict
        except Exception as exc:
            return exc
        return None

    async def _run(self, request: Request, victims: list[Request]) -> None:
        try:
            if victims:
                await self._wait_stopped(victims)
            result = request.service.func(self.component, **request.inputs)
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
            self._genom_state.changed()

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
        """The ``{"ex": ..., "detail": ...}`` object of an exception raised by the instance's services."""
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
            self._genom_state.changed()

    async def _wait_stopped(self, requests: list[Request]) -> None:
        """Wait until every one of *requests* has ended (their stop paths have run)."""
        tasks = {r.task for r in requests if r.task is not None and not r.task.done()}
        if tasks:
            # asyncio.wait never cancels what it waits for: a cancelled waiter leaves the victims stopping.
            await asyncio.wait(tasks)
        for request in requests:
            self._end_unstarted(request)

    async def interrupt(self, request: Request, by: str) -> None:
        """Interrupt a running request and wait for its stop path to finish (its error names *by*)."""
        self._signal_interrupt(request, by)
        await self._wait_stopped([request])

    async def interrupt_all(self, by: str) -> None:
        """Interrupt every running request and wait for their stop paths (the instance stops)."""
        await asyncio.gather(*(self.interrupt(r, by=by) for r in self.requests.running()))

    async def abort(self, request_id: str) -> Request:
        """Interrupt the request *request_id* (``by: "abort"``) and return it."""
        request = self.requests.get(request_id)
        await self.interrupt(request, by="abort")
        return request

    async def request(self, request_id: str) -> Request:
        """The request *request_id*.

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

    async def session_ended(self, session: str, sent_by: Callable[[Request], bool] | None = None) -> None:
        """*session* ended: hand its running requests (those *sent_by* one gateway) to the component's hook."""
        requests = [r for r in self.requests.running()
                    if r.session == session and (sent_by is None or sent_by(r))]
        if requests:
            await self.component.on_session_end(session, requests)
