"""The host side: one component instance offered on Zenoh (queries, publications, a liveliness token).

The component runs on the ordinary runtime; this only translates.  Requests go to the component's
request engine (``component.engine``), which the gateway's routes reach too, and a refusal is
answered with the genomix error the gateway would answer (``error_body`` of the runtime), so the
gateway in front of it only relays.  A request belongs to the gateway that sent it: its events go
to that gateway alone, and another gateway may not see, abort or clean it.  Each out port's
publications leave once, whoever reads them: a delta of the new items for numbered data (the audio
window), the data itself otherwise.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import sys
import weakref
from collections.abc import Callable, Coroutine
from typing import TYPE_CHECKING, Any

import orjson
import zenoh

from ..components.core import Chunked, Component, Incremental, OutPortRuntime, ThrottledLog
from ..components.core.runtime import (
    SENDER_SCOPE, ComponentError, ComputedOutPortRuntime, NoSuchRequest, Request, RequestStatus, error_body,
)
from ._session import on_zenoh_thread
from ._wire import (
    arrays_of, cleaned_key, encode_message, error_reply, events_key, info_key, offer_token, ok_reply, port_key,
    request_key, snapshot_key,
)

if TYPE_CHECKING:
    from ._host_node import HostNode

__all__ = ["ComponentExporter", "PortEncoder"]

log = logging.getLogger(__name__)
#: Lines that gateways' comings and goings cause (an unload, a dead-man), and faults while publishing a
#: port (each place's traceback once): rate-limited, as a client can repeat them.
_throttled = ThrottledLog(log)

#: Python 3.12 runs a task's first step at once: a query the component answers without waiting (most of
#: them) is answered in the loop turn that took it, with no second turn to schedule the task.
_EAGER: dict[str, Any] = {"eager_start": True} if sys.version_info >= (3, 12) else {}

#: Seconds between two publications of a computed port (its data is made when read, on each change).
#: genom_state changes with every request: a host that gets one call every few tens of milliseconds (calls
#: spread over many hosts) would publish it once per call at a shorter period, a message and two thread
#: wake-ups more per call in the host and in the gateway.  A quarter of a second, as the heartbeat: a
#: monitoring port, current within that.
COMPUTED_PERIOD = 0.25


class PortEncoder:
    """Turns the publications of one out port into port messages (see ``_wire``), remembering what was sent.

    Args:
        port: The out port.
    """

    def __init__(self, port: OutPortRuntime[Any]) -> None:
        self.port = port
        #: The port version the last messages carried.
        self.version = port.version
        #: Whether the last message said the data was withdrawn (the next publication says otherwise).
        self.withdrawn = False
        self._sent: int | None = None
        self._counts: dict[str, int] | None = None

    def due(self) -> bool:
        """Whether the port changed since the last messages: a publication, or its data withdrawn."""
        return self.port.version != self.version or (self.port.withdrawn is not None) != self.withdrawn

    def _withdrawal(self) -> bytes:
        """The message saying the data is withdrawn, with the component's reason (its exception object)."""
        reason = self.port.withdrawn
        assert reason is not None
        owner = self.port.owner
        body = owner.engine.exception_object(reason) if isinstance(owner, Component) else {"ex": reason.id}
        return encode_message(self.port.name, None, None, kind="withdrawn", reason=body)

    def _struct(self, value: Any, since: int | None) -> tuple[Any, int]:
        if isinstance(value, Chunked):
            data, lost = value.chunked(since)
        elif since is None:
            data, lost = value, 0
        else:
            data, lost = value.since(since)
        return self.port.type.encode(data), lost

    def _count_members(self, value: Any, whole: Any) -> dict[str, int]:
        """The members of numbered data that count an array's elements (``nbframes``), by array number.

        They are the members a read of no item gives as 0 while the whole read gives its array's
        length: the gateway sets them for each ``since=`` read it answers.
        """
        if self._counts is not None or not isinstance(whole, dict):
            return self._counts or {}
        empty, _ = self._struct(value, value.index)
        full: list[Any] = []
        none: list[Any] = []
        arrays_of(whole, full)
        arrays_of(empty, none)
        counts: dict[str, int] = {}
        if not any(len(a) for a in full):
            return counts  # nothing to tell the members apart by yet
        for member, number in whole.items():
            if isinstance(number, bool) or not isinstance(number, int):
                continue
            for at, (array, nothing) in enumerate(zip(full, none, strict=True)):
                if len(array) and number == len(array) and empty.get(member) == len(nothing) == 0:
                    counts[member] = at
                    break
        self._counts = counts
        return counts

    def base(self) -> bytes:
        """The whole data now (a numbered window with its items marked)."""
        if self.port.spec.multiple:
            raise ValueError("a multiple port has no single base: its elements are sent one by one")
        if self.port.withdrawn is not None:
            return self._withdrawal()
        value = self.port.read()
        if not isinstance(value, Incremental):
            data = self.port.type.encode(value)
            return encode_message(self.port.name, data, data, kind="value")
        whole, _ = self._struct(value, None)
        held, lost = self._struct(value, 0)
        found: list[Any] = []
        arrays_of(held, found)
        return encode_message(self.port.name, whole, whole, kind="base", index=value.index,
                              items=max(0, value.index - lost), held=[len(a) for a in found],
                              counts=self._count_members(value, whole))

    def messages(self) -> list[bytes]:
        """The messages of the publications since the last call (one per element of a multiple port)."""
        port = self.port
        self.version = port.version
        if port.withdrawn is not None:
            # Once: the gateways refuse the data until the next publication, which is a whole message.
            if self.withdrawn:
                return []
            self.withdrawn, self._sent = True, None
            return [self._withdrawal()]
        self.withdrawn = False
        if port.spec.multiple:
            out = []
            for element in port.elements():
                data = port.type.encode(port.read(element))
                out.append(encode_message(port.name, data, data, kind="value", element=element))
            return out
        value = port.read()
        if not isinstance(value, Incremental):
            data = port.type.encode(value)
            return [encode_message(port.name, data, data, kind="value")]
        if self._sent is None or value.index < self._sent:
            # The first message, or a new acquisition numbering from 1 again: the whole window.
            self._sent = value.index
            return [self.base()]
        prev, self._sent = self._sent, value.index
        whole, _ = self._struct(value, None)
        delta, lost = self._struct(value, prev)
        return [encode_message(port.name, whole, delta, kind="delta", index=value.index, prev=prev + lost,
                               counts=self._count_members(value, whole))]


class ComponentExporter:
    """Offers one component instance on a Zenoh session until :meth:`close`.

    Args:
        node: The host's presence on Zenoh (its session, its id, the gateways it hears of).
        component: The started instance.
    """

    def __init__(self, node: HostNode, component: Component) -> None:
        session = node.session
        self.node = node
        self.session = session
        self.component = component
        #: What runs the instance's requests: the gateways' sends, aborts and cleans go to it.
        self.engine = component.engine
        self.loop = node.loop
        self.instance = component.instance
        zid = node.zid
        self._declared: list[Any] = []
        self._tasks: set[asyncio.Task[Any]] = set()
        self._pending_events: list[tuple[RequestStatus, bytes]] = []
        # Requests whose end a send reply carried in this loop turn: their events are news to nobody.
        self._answered: set[RequestStatus] = set()
        #: The gateway that sent each request (the requests are the tracker's: they go when it forgets them).
        self._owners: weakref.WeakKeyDictionary[RequestStatus, str] = weakref.WeakKeyDictionary()
        #: The proxy of that gateway that sent it (a gateway may load one instance under two names).
        self._via: weakref.WeakKeyDictionary[RequestStatus, str] = weakref.WeakKeyDictionary()
        #: Who sent the last motion, as (gateway, proxy): when it lets go, what it set going stops.
        self._last_mover: tuple[str, str] | None = None
        self._events: dict[str, Any] = {}
        self._declared.append(session.declare_queryable(info_key(zid, self.instance),
                                                        on_zenoh_thread(self._on_query(self._info))))
        self._declared.append(session.declare_queryable(request_key(zid, self.instance, "*"),
                                                        on_zenoh_thread(self._on_query(self._request))))
        self._declared.append(session.declare_queryable(snapshot_key(zid, self.instance, "*"),
                                                        on_zenoh_thread(self._on_query(self._snapshot))))
        self._declared.append(session.declare_subscriber(cleaned_key(zid, self.instance, "*"),
                                                         on_zenoh_thread(self._on_clean)))
        self._encoders: dict[str, PortEncoder] = {}
        self._publishers: dict[str, Any] = {}
        for name, spec in type(component).ports().items():
            if spec.direction != "out":
                continue
            port = component.port(name)
            assert isinstance(port, OutPortRuntime)
            encoder = self._encoders[name] = PortEncoder(port)
            # Reliable and blocking: a dropped delta would be a gap (a loss).  Express like the replies and
            # events: nothing is held back in a batch, so all leave in the order they are made.
            publisher = self._publishers[name] = session.declare_publisher(
                port_key(zid, self.instance, name), congestion_control=zenoh.CongestionControl.BLOCK,
                reliability=zenoh.Reliability.RELIABLE, express=True)
            self._declared.append(publisher)
            task = self.loop.create_task(self._pump(encoder, publisher), name=f"zenoh {self.instance}/{name}")
            task.add_done_callback(self._pump_ended)
            self._tasks.add(task)
        component.host.add_request_listener(self._on_request)
        # Last: the gateway that sees the token finds everything above declared.
        self._token = session.liveliness().declare_token(offer_token(node.host_id, zid, self.instance))

    # -- queries ----------------------------------------------------------------------------

    def _on_query(self, handler: Callable[[zenoh.Query], Coroutine[Any, Any, Any]]) -> Callable[[zenoh.Query], None]:
        def on_query(query: zenoh.Query) -> None:
            # On a Zenoh thread: the component is touched on its loop only.
            self.loop.call_soon_threadsafe(self._start, handler, query)

        return on_query

    def _start(self, handler: Callable[[zenoh.Query], Coroutine[Any, Any, Any]], query: zenoh.Query) -> None:
        task = asyncio.Task(self._answer(handler, query), loop=self.loop, **_EAGER)
        if not task.done():
            self._tasks.add(task)
            task.add_done_callback(self._tasks.discard)

    async def _answer(self, handler: Callable[[zenoh.Query], Coroutine[Any, Any, Any]], query: zenoh.Query) -> None:
        try:
            try:
                answer = await handler(query)
            except Exception as exc:
                status, error = error_body(exc)
                if status >= 500:
                    log.exception("%s: query %s failed", self.instance, query.key_expr)
                answer = error_reply(status, error)
            # What the component published before answering reaches the gateway before the answer.
            self._flush_ports()
            # A multiple port's snapshot is one reply per element.
            for body in answer if isinstance(answer, list) else [answer]:
                query.reply(query.key_expr, body, express=True)
        except zenoh.ZError:
            pass  # the querier gave up (timeout): nobody to answer
        finally:
            query.drop()  # type: ignore[no-untyped-call]

    @staticmethod
    def _payload(query: zenoh.Query) -> dict[str, Any]:
        raw = query.payload.to_bytes() if query.payload is not None else b"null"
        payload = orjson.loads(raw) if raw else None
        return payload if isinstance(payload, dict) else {}

    async def _info(self, query: zenoh.Query) -> bytes:
        return ok_reply(self.component.description())

    async def _request(self, query: zenoh.Query) -> bytes:
        operation = str(query.key_expr).rsplit("/", 1)[-1]
        payload = self._payload(query)
        gateway = str(payload.get("gateway", ""))
        if not gateway:
            message = "a request names the gateway that sends it (remote protocol 2)"
            return error_reply(400, {"ex": "::genom::serialization", "detail": {"what": message}, "message": message})
        engine = self.engine
        self._clean_answered(gateway, payload.get("cleaned"))
        via = str(payload.get("via", ""))
        if operation == "send":
            # A request may name only this gateway's requests (abort_activity): another's are unknown.
            scope = SENDER_SCOPE.set(lambda request: self._owners.setdefault(request, gateway) == gateway)
            try:
                request = await engine.send(payload.get("service", ""), payload.get("input"),
                                            session=payload.get("session"), oneway=bool(payload.get("oneway")))
            finally:
                SENDER_SCOPE.reset(scope)
            self._owners[request] = gateway
            self._via[request] = via
            if request.service.motion and request.status != "error":
                # Even one that ended at once (a speed command) may have left the robot moving.
                self._last_mover = (gateway, via)
                self.node.expect_gateway(gateway)
            if not (request.running or request.oneway):
                self._answered.add(request)
            return ok_reply(_status_with_serial(request))
        if operation == "release":
            stopped = await self.let_go(gateway, via=via, by="kill")
            return ok_reply({"ended": [_status_with_serial(request) for request in stopped]})
        if operation == "session_ended":
            # Sessions are a gateway's: another gateway's session of the same name is another session.
            await engine.session_ended(str(payload.get("session", "")),
                                       sent_by=lambda request: self._owners.get(request) == gateway)
            return ok_reply(None)
        request_id = str(payload.get("id", ""))
        if operation == "status":
            return ok_reply(_status_with_serial(self._owned(request_id, gateway)))
        if operation == "abort":
            return ok_reply(_status_with_serial(await engine.abort(self._owned(request_id, gateway).id)))
        if operation == "clean":
            await engine.clean(self._owned(request_id, gateway).id)
            return ok_reply(None)
        return error_reply(404, {"ex": "::genomix::http", "message": f"no request operation {operation!r}"})

    def _owned(self, request_id: str, gateway: str) -> Request:
        """The request *request_id* when gateway *gateway* sent it, or adopted it (its sender vanished).

        Raises:
            NoSuchRequest: when there is none, or another gateway sent it (sessions, requests and events of
                one gateway never reach another's clients).
        """
        request = self.engine.requests.get(request_id)
        owner = self._owners.setdefault(request, gateway)  # an orphan's: adopted, its events go there now
        if owner != gateway:
            raise NoSuchRequest(f"no request {request.id} of this gateway (another gateway sent it)")
        return request

    async def _snapshot(self, query: zenoh.Query) -> list[bytes]:
        name = str(query.key_expr).rsplit("/", 1)[-1]
        encoder = self._encoders.get(name)
        if encoder is None:
            return [error_reply(404, {"ex": "::genom::no_such_outport", "message": f"no out port {name!r}"})]
        if encoder.port.spec.multiple:
            return PortEncoder(encoder.port).messages()
        return [encoder.base()]

    def _on_clean(self, sample: zenoh.Sample) -> None:
        gateway = str(sample.key_expr).rsplit("/", 1)[-1]
        body = sample.payload.to_bytes()
        self.loop.call_soon_threadsafe(self._clean_published, gateway, body)

    def _clean_published(self, gateway: str, body: bytes) -> None:
        try:
            ids = orjson.loads(body).get("ids")
        except (ValueError, AttributeError):
            ids = None
        self._clean_answered(gateway, ids)

    def _clean_answered(self, gateway: str, ids: Any) -> None:
        """Cleans a gateway answered itself (it saw the requests end): nothing to report back."""
        if not isinstance(ids, list):
            return
        for request_id in ids:
            try:
                self.engine.requests.clean(self._owned(str(request_id), gateway).id)
            except (ComponentError, ValueError) as exc:
                log.debug("%s: clean answered by the gateway not applied: %s", self.instance, exc)

    # -- the dead-man -------------------------------------------------------------------------

    async def orphan(self, gateway: str) -> list[Request]:
        """Gateway *gateway* vanished: interrupt the motions it started; return them once stopped.

        Only activities declared ``motion=True`` stop: a capture or a recording goes on, its data
        kept for whoever reads it next.  Its other requests then belong to no gateway: the first
        gateway that asks for one (its status, an abort, a clean) adopts it, and hears its events.
        When it sent the last motion, what that motion left going stops too (``stop_motions``).
        Its sessions ended with it: the component hears of each that sent a request that runs.
        """
        def sent_by(request: Request) -> bool:
            return self._owners.get(request) == gateway

        for session in dict.fromkeys(r.session for r in self.engine.requests.running() if sent_by(r)):
            if session is not None:
                try:
                    await self.engine.session_ended(session, sent_by=sent_by)
                except Exception as exc:  # noqa: BLE001  # a fault of the component: said, and the rest goes on
                    _throttled.error("%s: the end of session %r failed: %s", self.instance, session, exc, exc=exc)
        return await self.let_go(gateway, via=None, by="gateway_gone")

    async def let_go(self, gateway: str, *, via: str | None, by: str) -> list[Request]:
        """Stop the motions of *gateway* (of its proxy *via* only, when given); let its other requests go.

        The running motions are interrupted (``by`` says why: ``gateway_gone`` for the dead-man,
        ``kill`` for an unload, as a local unload says); then, when that gateway (that proxy) sent
        the last motion, the component's ``stop_motions`` stops what a command that ended left
        going.  The gateway's other requests belong to nobody from now on (see :meth:`orphan`).
        Returns the motions interrupted.
        """
        def sent_by(request: RequestStatus) -> bool:
            return self._owners.get(request) == gateway and via in (None, self._via.get(request))

        theirs = [request for request in self.engine.requests.running() if sent_by(request)]
        motions = [request for request in theirs if request.service.motion]
        why = "the gateway that started it is gone (dead-man)" if by == "gateway_gone" else "its gateway unloaded it"
        for request in motions:
            _throttled.warning("%s: stopping %s (%s): %s", self.instance, request.id, request.service.name, why)
        await asyncio.gather(*(self.engine.interrupt(request, by=by) for request in motions))
        last = self._last_mover
        if last is not None and last[0] == gateway and via in (None, last[1]):
            self._last_mover = None
            _throttled.warning("%s: stopping what the last motion left going: %s", self.instance, why)
            try:
                await self.component.stop_motions()
            except Exception as exc:  # noqa: BLE001  # a fault of the component: said, and the rest goes on
                _throttled.error("%s: stop_motions failed: %s", self.instance, exc, exc=exc)
        for request in theirs:
            self._owners.pop(request, None)
        return motions

    # -- publications -----------------------------------------------------------------------

    def _on_request(self, request: RequestStatus) -> None:
        if request.instance != self.instance or request.oneway:
            return
        event = orjson.dumps({"status": _status_with_serial(request), "session": request.session})
        if not self._pending_events:
            # Published at the end of this loop turn: the reply to a send that ended its request at
            # once goes first (the caller waits on it), its events after, if still news.
            self.loop.call_soon(self._publish_events)
        self._pending_events.append((request, event))

    def _publisher_to(self, gateway: str) -> Any:
        publisher = self._events.get(gateway)
        if publisher is None:
            publisher = self._events[gateway] = self.session.declare_publisher(
                events_key(self.node.zid, self.instance, gateway), congestion_control=zenoh.CongestionControl.BLOCK,
                reliability=zenoh.Reliability.RELIABLE, express=True)
        return publisher

    def _publish_events(self) -> None:
        # A request's end comes after what it published: a read once it is done sees its last data.
        self._flush_ports()
        events, self._pending_events = self._pending_events, []
        answered, self._answered = self._answered, set()
        for request, event in events:
            # The gateway that sent a request which ended at once took its end from the reply, and
            # announced it to the request's session: the only listener there is (sessions belong to
            # a gateway).  Two messages fewer per such call.
            gateway = self._owners.get(request)
            if request not in answered and gateway is not None:
                self._publisher_to(gateway).put(event)

    def forget_gateway(self, gateway: str) -> None:
        """Undeclare the publisher of a gateway that vanished."""
        publisher = self._events.pop(gateway, None)
        if publisher is not None:
            with contextlib.suppress(zenoh.ZError):
                publisher.undeclare()

    def _flush_ports(self) -> None:
        """Publish now the ports that changed since their last message (not the computed ones: see _pump)."""
        for name, encoder in self._encoders.items():
            if encoder.due() and not isinstance(encoder.port, ComputedOutPortRuntime):
                self._publish(encoder, self._publishers[name])

    def _publish(self, encoder: PortEncoder, publisher: Any) -> None:
        """Send the messages of what changed on a port; a fault of ours is logged, never the caller's end."""
        try:
            for message in encoder.messages():
                publisher.put(message)
        except zenoh.ZError:
            pass  # the session is closing
        except Exception as exc:  # noqa: BLE001  # a reply or an event must not be lost to a port's fault
            _throttled.error("%s: port %s not published: %s", self.instance, encoder.port.name, exc, exc=exc)

    async def _pump(self, encoder: PortEncoder, publisher: Any) -> None:
        port = encoder.port
        # A computed port (genom_state) changes with every request: it is sent at most every
        # COMPUTED_PERIOD, its last state always, so that requests do not pay for it one by one.
        pause = COMPUTED_PERIOD if isinstance(port, ComputedOutPortRuntime) else 0.0
        while True:
            if not encoder.due():
                # A publication, or the data withdrawn (which wakes this too, with no new version).
                await asyncio.shield(port.next_publication())
                continue
            if pause:
                await asyncio.sleep(pause)
            if encoder.due():  # not flushed before a reply meanwhile
                self._publish(encoder, publisher)

    def _pump_ended(self, task: asyncio.Task[Any]) -> None:
        if not task.cancelled() and task.exception() is not None:
            log.error("%s: %s stopped: gateways no longer get its data", self.instance, task.get_name(),
                      exc_info=task.exception())

    async def close(self) -> None:
        """Withdraw the instance: the token first (the gateway hears it is gone), then the rest."""
        with contextlib.suppress(zenoh.ZError):
            self._token.undeclare()  # type: ignore[no-untyped-call]
        self.component.host.remove_request_listener(self._on_request)
        tasks = list(self._tasks)
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        for declared in [*self._declared, *self._events.values()]:
            with contextlib.suppress(zenoh.ZError):
                declared.undeclare()
        self._events.clear()


def _status_with_serial(request: RequestStatus) -> dict[str, Any]:
    """The status object plus the request's serial, which tells the gateway's copies of one number apart.

    Numbers are reused after a clean, and events travel after replies: without the serial, a late
    event of a cleaned request would look like news of the next request under its number.
    """
    status = request.status_object()
    status["serial"] = request.serial
    return status
