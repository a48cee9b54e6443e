"""A robot's host and gateways on real Zenoh sessions in this process: what a gateway lets go of, and when.

Withdrawn data reaches every gateway; an unload stops the motions the gateway sent there; a gateway
that vanishes stops what its motions set going, even after they ended; one gateway never aborts
another's request; a host whose components were all killed exits; an unload never waits for a load
that waits for the network.  One process, two or three Zenoh sessions on loopback: no process start.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import math
from collections.abc import AsyncIterator, Sequence
from typing import Annotated, Any

import aiohttp
import pytest
import zenoh

from aiogenomix.components.core import (
    Component, ComponentHost, Double, GenomException, InPort, Long, OutPort, String, activity, function, idl_struct,
)
from aiogenomix.components.core.runtime import (
    AmbiguousModule, PortUnavailable, RemoteUnreachable, TooManyInstances, error_body,
)
from aiogenomix.components.recorder import Recorder
from aiogenomix.gateway import GatewayConfig
from aiogenomix.gateway import serve as serve_gateway
from aiogenomix.remote import HostNode, RemoteInstance, RemoteTimeouts, ZenohDirectory, ZenohSettings
from aiogenomix.remote._host_main import parse_args, serve
from aiogenomix.remote._session import open_session
from aiogenomix.remote._wire import info_key, offer_token

from ._processes import free_port

#: Seconds a test waits for what Zenoh delivers at once on loopback (a bound, not a pace).
WITHIN = 10.0


@idl_struct("turner::frame")
class Frame:
    seq: Long = 0


class DOWN(GenomException):
    """The sensor is down."""

    what: String


class Turner(Component, name="turner", version="1.0"):
    """A motor that keeps the speed it was last given, a sensor that can go down, a recording that goes on."""

    Reading = OutPort(Frame, doc="the sensor")

    async def on_start(self) -> None:
        self.speed = 0.0
        self.stopped = asyncio.Event()
        self.Reading.publish(Frame(1))

    @activity(motion=True)
    async def Spin(self, speed: Annotated[Double, "deg/s"] = 0.0) -> None:
        """One speed command: the motor keeps turning after the request ended (as morse_kemar's Rotate)."""
        self.speed = speed
        self.stopped.clear()

    @activity(motion=True)
    async def Move(self) -> None:
        """A move that runs until interrupted."""
        await asyncio.get_running_loop().create_future()

    @activity
    async def Record(self) -> None:
        """A recording: no motion, it runs until aborted."""
        await asyncio.get_running_loop().create_future()

    @function
    def Down(self) -> None:
        """The sensor goes down."""
        self.Reading.withdraw(DOWN(what="sensor unplugged"))

    async def stop_motions(self) -> None:
        self.speed = 0.0
        self.stopped.set()


@contextlib.asynccontextmanager
async def robot(endpoint: str, *names: str,
                offered: Sequence[str] | None = None) -> AsyncIterator[tuple[ComponentHost, HostNode]]:
    """A component host running *names* (turners) and offering them (or those *offered*) on *endpoint*.

    As aiogenomix-component runs it.
    """
    host = ComponentHost(factories={"turner": Turner})
    for name in names:
        await host.load("turner", [] if name == "turner" else ["-i", name])
    directory = await ZenohDirectory.open(ZenohSettings(listen=[endpoint]), gateway=False)
    host.finder = directory
    host.shared("zenoh", lambda: directory)
    node = HostNode(directory.session, host, "robot1", [endpoint])
    for name in names if offered is None else offered:
        component = host.get(name)
        assert isinstance(component, Component)
        node.offer(component)
    try:
        yield host, node
    finally:
        await node.close()
        await host.close()


@contextlib.asynccontextmanager
async def gateway(*endpoints: str, control: float = 5.0,
                  offers: int = 1) -> AsyncIterator[tuple[ComponentHost, ZenohDirectory]]:
    """A gateway's host and directory, connected to *endpoints*, once it heard *offers* offers."""
    host = ComponentHost(factories={})
    heard = 0
    enough = asyncio.Event()

    def offered(_: dict[str, Any]) -> None:
        nonlocal heard
        heard += 1
        if heard >= offers:
            enough.set()

    directory = await ZenohDirectory.open(ZenohSettings(connect=list(endpoints)),
                                          RemoteTimeouts(control=control, send=control, stale=5.0),
                                          on_offered=offered)
    host.finder = directory
    host.shared("zenoh", lambda: directory)
    try:
        await asyncio.wait_for(enough.wait(), WITHIN)
        yield host, directory
    finally:
        await host.close()


class Withdrawing:
    """A host's Zenoh session caught withdrawing ``turner``: its offer still stands, its queries go unanswered.

    Each query of turner's description is dropped without a reply (the queryable went as it came),
    as on a host whose exporter is closing while the gateway has not yet heard its token go.
    """

    def __init__(self, session: zenoh.Session) -> None:
        self.session = session
        self.zid = str(session.zid())
        #: Set once a query of the description came, and was dropped.
        self.asked = asyncio.Event()
        loop = asyncio.get_running_loop()

        def drop(query: zenoh.Query) -> None:
            loop.call_soon_threadsafe(self.asked.set)
            query.drop()

        self._queryable = session.declare_queryable(info_key(self.zid, "turner"), drop)
        self._token = session.liveliness().declare_token(offer_token("robot1", self.zid, "turner"))

    def withdraw(self) -> None:
        """The withdrawal ends: the offer's token goes."""
        self._token.undeclare()


@contextlib.asynccontextmanager
async def withdrawing(endpoint: str) -> AsyncIterator[Withdrawing]:
    """A :class:`Withdrawing` host listening on *endpoint*."""
    session, _ = await asyncio.to_thread(open_session, ZenohSettings(listen=[endpoint]))
    try:
        yield Withdrawing(session)
    finally:
        await asyncio.to_thread(session.close)


@pytest.fixture
def endpoint() -> str:
    return f"tcp/127.0.0.1:{free_port()}"


def _turner(host: ComponentHost, name: str = "turner") -> Turner:
    component = host.get(name)
    assert isinstance(component, Turner)
    return component


async def test_withdrawn_data_reaches_every_gateway_and_comes_back(endpoint: str) -> None:
    async with robot(endpoint, "turner") as (robot_host, _), gateway(endpoint) as (gateway_host, _):
        proxy = await gateway_host.load("turner")
        mirror = proxy.port("Reading")
        assert mirror.read() == {"seq": 1}
        down = await proxy.send("Down")
        assert down.status == "done"
        # What the host published before its reply came first: the gateway refuses the data now.
        with pytest.raises(PortUnavailable) as refused:
            mirror.read()
        assert error_body(refused.value)[0] == 503
        assert error_body(refused.value)[1]["ex"] == "::turner::DOWN"
        assert error_body(refused.value)[1]["detail"] == {"what": "sensor unplugged"}
        # A gateway that comes later learns it from the port's snapshot.
        async with gateway(endpoint) as (later, _):
            with pytest.raises(PortUnavailable):
                (await later.load("turner")).port("Reading").read()
            # Data published again is current again, in both.
            published = mirror.next_publication()
            _turner(robot_host).Reading.publish(Frame(2))
            await asyncio.wait_for(asyncio.shield(published), WITHIN)
            assert mirror.read() == {"seq": 2}


async def test_an_unload_stops_the_gateway_s_motions_there_and_leaves_the_rest(endpoint: str) -> None:
    async with robot(endpoint, "turner") as (robot_host, _), gateway(endpoint) as (gateway_host, _):
        turner = _turner(robot_host)
        proxy = await gateway_host.load("turner")
        move, record = await proxy.send("Move"), await proxy.send("Record")
        spin = await proxy.send("Spin", {"speed": 30.0})
        await asyncio.wait_for(spin.ended.wait(), WITHIN)
        assert spin.status == "done" and turner.speed == 30.0
        await gateway_host.unload("turner")
        # As a local unload: the motions were interrupted before the unload returned, and what their
        # commands set going stopped too; a recording is the robot's, and goes on.
        assert move.exception == {"ex": "::genom::interrupted", "detail": {"by": "kill"}}
        assert turner.speed == 0.0
        running = {r.service.name for r in turner.requests.running()}
        assert running == {"Record"}
        assert record.exception is not None and record.exception["ex"] == "::genom::remote_io"
        assert "goes on" in record.exception["detail"]["what"]


async def test_a_vanished_gateway_s_last_command_is_stopped_though_its_request_ended(endpoint: str) -> None:
    async with robot(endpoint, "turner") as (robot_host, _):
        turner = _turner(robot_host)
        async with gateway(endpoint) as (gateway_host, directory):
            proxy = await gateway_host.load("turner")
            spin = await proxy.send("Spin", {"speed": 30.0})
            await asyncio.wait_for(spin.ended.wait(), WITHIN)
            assert turner.speed == 30.0 and not turner.requests.running()
            # The gateway's process dies: its session ends without unloading anything.
            gateway_host.finder = None
            await directory.aclose()
            await asyncio.wait_for(turner.stopped.wait(), WITHIN)
            assert turner.speed == 0.0


async def test_another_gateway_cannot_abort_a_request_by_its_number(endpoint: str) -> None:
    async with robot(endpoint, "turner") as (robot_host, _), gateway(endpoint) as (first, _), \
            gateway(endpoint) as (second, _):
        record = await (await first.load("turner")).send("Record")
        intruder = await (await second.load("turner")).send("abort_activity", {"activity": record.number})
        await intruder.ended.wait()
        assert intruder.exception == {"ex": "::genom::no_such_activity"}
        assert record.running and [r.service.name for r in _turner(robot_host).requests.running()] == ["Record"]
        own = await (await first.load("turner")).send("abort_activity", {"activity": record.number})
        await own.ended.wait()
        await asyncio.wait_for(record.ended.wait(), WITHIN)
        assert own.status == "done" and record.exception == {"ex": "::genom::interrupted",
                                                             "detail": {"by": "abort_activity"}}


async def test_a_host_whose_components_were_all_killed_exits(endpoint: str) -> None:
    args = parse_args(["demo", "--host-id", "robot1", "--zenoh-listen", endpoint])
    stop = asyncio.Event()
    serving = asyncio.create_task(serve(args, stop))
    try:
        async with gateway(endpoint) as (gateway_host, _):
            demo = await gateway_host.load("demo")
            await demo.send("kill")
            await asyncio.wait_for(asyncio.shield(serving), WITHIN)
    finally:
        stop.set()
        await serving


async def test_a_host_closes_though_its_heartbeat_is_hurried_as_it_closes(endpoint: str) -> None:
    # A gateway that goes hurries the heartbeat (its hear token goes before its gateway token, and a
    # gateway that asks nothing gets the shortest period), often just as the host closes. A heartbeat
    # woken in the very loop turn that cancels it must still stop: with ``asyncio.wait_for`` on
    # Python 3.11 the cancellation was lost and the host's close waited for the heartbeat for ever
    # (the flake hunt's quiet run 8 of 2573bcc, in test_withdrawn_data_reaches_every_gateway_and_comes_back).
    async with robot(endpoint) as (_, node):
        await asyncio.sleep(0)          # one turn: the heartbeat, made with the node, is in its wait
        node._hurry.set()               # what a hearer that goes does (HostNode._hearer_changed) ...
        closing = node.close()          # ... in the turn that cancels the heartbeat
        await asyncio.wait_for(closing, WITHIN)


async def test_an_unload_does_not_wait_for_a_load_waiting_for_its_host(endpoint: str) -> None:
    async with robot(endpoint, "turner", "other") as (_, node), \
            gateway(endpoint, control=60.0, offers=2) as (gateway_host, _):
        other = await gateway_host.load("other")
        exporter = node.withdraw("turner")
        assert exporter is not None
        await exporter.close()
        # The gateway heard of turner: a load waits for its host to offer it again (up to 60 s).
        waiting = asyncio.create_task(gateway_host.load("turner"))
        await asyncio.sleep(0)  # the load starts (and, before, took the host's lock)
        try:
            await asyncio.wait_for(gateway_host.unload("other"), WITHIN / 2)
            assert "other" not in gateway_host.instances and not waiting.done()
            assert isinstance(other, RemoteInstance)
        finally:
            waiting.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await waiting


async def test_a_load_that_races_a_withdrawal_waits_for_the_next_offer(endpoint: str) -> None:
    old_run = f"tcp/127.0.0.1:{free_port()}"
    async with withdrawing(old_run) as withdrawn, \
            robot(endpoint, "turner", "other", offered=["other"]) as (robot_host, node), \
            gateway(endpoint, old_run, control=60.0, offers=2) as (gateway_host, _):
        loading = asyncio.create_task(gateway_host.load("turner"))
        try:
            # Its description was asked of the run withdrawing it, and nothing answered: not a timeout.
            await asyncio.wait_for(withdrawn.asked.wait(), WITHIN)
            withdrawn.withdraw()
            # Another run offers turner: the load waited for it, as it waits for any restarting host.
            node.offer(_turner(robot_host))
            proxy = await asyncio.wait_for(asyncio.shield(loading), WITHIN)
            assert isinstance(proxy, RemoteInstance) and proxy.offer.zid == node.zid
        finally:
            loading.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await loading


async def test_a_load_of_an_offer_nothing_answers_for_says_so(endpoint: str) -> None:
    async with withdrawing(endpoint) as withdrawn, gateway(endpoint, control=1.0) as (gateway_host, _):
        with pytest.raises(RemoteUnreachable) as refused:
            await gateway_host.load("turner")
        assert withdrawn.asked.is_set()
        message = str(refused.value)
        assert "turner@robot1 is still offered, but nothing answered for it within 1 s" in message
        assert "no answer within" not in message


async def test_a_silent_host_s_port_is_refused_before_a_watch_starts(endpoint: str) -> None:
    async with robot(endpoint, "turner"), gateway(endpoint) as (gateway_host, _), \
            serve_gateway(GatewayConfig.of(port=0), gateway_host) as url, aiohttp.ClientSession(base_url=url) as http:
        proxy = await gateway_host.load("turner")
        assert isinstance(proxy, RemoteInstance)
        async with http.get("/module/turner/read/Reading") as reply:
            assert reply.status == 200
        # The host falls silent (a cut link): no heartbeat, no message since long before the bound.
        proxy.link = dataclasses.replace(proxy.link, silence=lambda zid: math.inf)
        proxy._last_message = -math.inf
        for path in ("/module/turner/read/Reading", "/module/turner/watch/Reading"):
            async with http.get(path) as reply:
                body = await reply.json()
                assert (reply.status, body["ex"]) == (504, "::genom::remote_io"), path
                assert "not heard from" in body["message"]


class _Refusing:
    """A finder whose every name is refused the way a remote layer refuses it."""

    def __init__(self, refusal: Exception) -> None:
        self.refusal = refusal

    async def find(self, host: ComponentHost, name: str, argv: list[str]) -> None:
        raise self.refusal

    def offered(self) -> list[str]:
        return []

    def may_run_here(self, name: str) -> bool:
        return True

    def view(self) -> dict[str, Any]:
        return {}

    def absent(self, instance: str) -> None:
        return None


class Listener(Component, name="listener"):
    Frames = InPort(Frame, doc="connect to turner/Reading")


@pytest.mark.parametrize(("refusal", "ex"), [
    (AmbiguousModule("turner is offered by 2 component hosts: load turner@robot1 or turner@robot2"),
     "::genom::port_io"),
    (RemoteUnreachable("turner runs on robot1, not heard from for 3.0 s"), "::genom::remote_io"),
    (TooManyInstances("64 instances are loaded"), "::genom::port_io"),
])
async def test_an_out_port_of_another_process_that_cannot_be_had_is_said_why(refusal: Exception, ex: str) -> None:
    async with ComponentHost(factories={"listener": Listener, "recorder": Recorder}) as host:
        listener, recorder = await host.load("listener"), await host.load("recorder")
        host.finder = _Refusing(refusal)
        connect = await listener.send("connect_port", {"local": "Frames", "remote": "turner/Reading"})
        await connect.ended.wait()
        assert connect.exception == {"ex": ex, "detail": {"what": str(refusal)}}
        start = await recorder.send("Start", {"path": "a.mcap", "ports": ["turner/Reading"]})
        await start.ended.wait()
        assert start.exception is not None and start.exception["ex"] == "::recorder::NO_SUCH_PORT"
        assert start.exception["detail"]["what"] == str(refusal)
