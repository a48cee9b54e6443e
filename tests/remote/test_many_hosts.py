"""Hosts behind one router, each in a network namespace of its own: what a host hears, and a host that vanishes.

Deployed as docs/remote.md says (a router, hosts and a gateway as its Zenoh clients), on the network
namespaces of ``bench/_netns.py``: what a host receives is counted on its own interface. Heavy (up to
eight processes): run once, on the default Python (``AIOGENOMIX_HEAVY=0`` skips them); root is needed.
"""

from __future__ import annotations

import asyncio
import json
import os
import pathlib
import shutil
import signal
from collections.abc import AsyncIterator, Iterable

import pytest

from aiogenomix.remote import RemoteTimeouts
from aiogenomix.remote._wire import beat_period
from bench._netns import INTERFACE, Star, star, unavailable

from ._namespaces import curl, packet_seen, python_in
from ._processes import Process, start_component_host, start_gateway, start_router

pytestmark = pytest.mark.skipif(os.environ.get("AIOGENOMIX_HEAVY") == "0",
                                reason="runs once, on the default Python (AIOGENOMIX_HEAVY=0)")

#: Seconds over which a host's received packets are counted.
WINDOW = 4.0


@pytest.fixture
async def lab() -> AsyncIterator[Star]:
    """A star of network namespaces (skipped, saying why, where it cannot be made)."""
    why = unavailable() or (None if shutil.which("curl") else "curl is not installed")
    if why is not None:
        pytest.skip(why)
    with star() as net:
        yield net


class Deployment:
    """A router on the lab's hub; hosts and a gateway on machines of their own, Zenoh clients of the router."""

    def __init__(self, lab: Star, started: list[Process], folder: pathlib.Path) -> None:
        self.lab = lab
        self.started = started
        self.router = f"tcp/{lab.hub_address}:7447"
        self.config = folder / "client.json5"
        self.config.write_text(json.dumps({"mode": "client", "connect": {"endpoints": [self.router]}}))
        self.hosts: dict[str, Process] = {}
        self.url = ""

    async def start(self, hosts: Iterable[str], *, gateway: bool = False) -> None:
        """The router (the first time), *hosts* (each offering ``demo`` as ``HOSTd``), and the gateway if asked."""
        if not self.started:
            self.started.append(await start_router(self.router, prefix=self.lab.on("hub")))

        async def host(name: str) -> None:
            self.lab.add(name)
            self.hosts[name] = await start_component_host(
                [f"demo:-i {name}d"], host_id=name, extra=["--zenoh-config", str(self.config)],
                prefix=self.lab.on(name))
            self.started.append(self.hosts[name])

        for name in hosts:  # one after another: the lab numbers its machines in order
            await host(name)
        if gateway:
            address = self.lab.add("gw")
            process, self.url = await start_gateway(extra=["--zenoh-config", str(self.config)], address=address,
                                                    prefix=self.lab.on("gw"))
            self.started.append(process)

    async def get(self, path: str) -> tuple[int, object]:
        """GET *path* of the gateway, from its machine."""
        return await curl(self.lab.on("gw"), f"{self.url}{path}")

    async def heard(self, hosts: set[str]) -> None:
        """Return once the gateway lists every host of *hosts* in ``/``."""
        async with asyncio.timeout(60):
            while {run["host"] for run in (await self.get("/"))[1]["zenoh"]["hosts"]} != hosts:  # type: ignore[index]
                await asyncio.sleep(0.1)  # the gateway is in another namespace: its own view, read again

    async def received(self, host: str, windows: int = 3) -> int:
        """The fewest packets *host* receives on its interface in one of *windows* windows of ``WINDOW`` seconds.

        A one-off exchange (the declarations that newcomers' offers bring, still arriving for a second or
        so after the gateway lists them) falls in one window; a periodic message, a beat, in every one.
        """
        counts = []
        for _ in range(windows):
            before, _ = self.lab.received(host)
            await asyncio.sleep(WINDOW)  # the measurement's window, not a synchronisation
            counts.append(self.lab.received(host)[0] - before)
        return min(counts)


async def test_a_host_hears_no_more_when_five_more_hosts_come(lab: Star, started: list[Process],
                                                               tmp_path: pathlib.Path) -> None:
    rig = Deployment(lab, started, tmp_path)
    await rig.start(["h01"], gateway=True)
    assert (await rig.get("/load/h01d"))[0] == 200
    await rig.heard({"h01"})
    alone = await rig.received("h01")
    await rig.start([f"h0{n}" for n in range(2, 7)])
    await rig.heard({f"h0{n}" for n in range(1, 7)})
    with_others = await rig.received("h01")
    # Each of the five beats as often as the gateway asks: a host that heard them would receive that many more
    # in every window.
    their_beats = 5 * WINDOW / beat_period(RemoteTimeouts().stale)
    assert with_others - alone < 0.25 * their_beats, (alone, with_others)


async def test_a_request_in_flight_when_its_host_vanishes_and_its_instance_after(
        lab: Star, started: list[Process], tmp_path: pathlib.Path) -> None:
    rig = Deployment(lab, started, tmp_path)
    await rig.start(["h01"], gateway=True)
    assert (await rig.get("/load/h01d"))[0] == 200
    host = rig.hosts["h01"]
    # Frozen first: the send's query reaches the host's machine and waits there; then the process dies.
    # The query itself, seen on the wire: a packet count also grows with the router's other traffic, and
    # a kill before the query left made the gateway refuse a send to a host it knew gone (another message).
    async with packet_seen(lab.on("h01"), INTERFACE, b"GetSpeed") as seen:
        host.kill(signal.SIGSTOP)
        sending = asyncio.ensure_future(rig.get("/module/h01d/send/GetSpeed"))
        assert await asyncio.wait_for(seen, 30) == b"seen\n"
    host.kill(signal.SIGKILL)
    status, error = await asyncio.wait_for(sending, 30)
    assert isinstance(error, dict) and error["ex"] == "::genom::remote_io", (status, error)
    message = error["message"]
    assert "h01 went away" in message and "last heard" in message, message
    assert "no answer within" not in message, message  # the query ended when the host did: no timeout
    # Its instance is not an unknown name: its host is gone, and may come back.
    status, error = await rig.get("/module/h01d/info")
    assert status == 503, (status, error)
    assert isinstance(error, dict) and error["ex"] == "::genom::remote_io"
    assert error["detail"]["host"] == "h01" and error["detail"]["last_heard"].endswith("Z"), error
    assert "h01d ran on component host h01" in error["message"] and "last heard" in error["message"], error
    # The Python client raises it as HostUnreachable, with the host and when it was last heard.
    caught = await python_in(lab.on("gw"), f"""
import json
from aiogenomix.clients import HostUnreachable, connect
with connect({rig.url!r}) as gateway:
    try:
        gateway.module("h01d")
    except HostUnreachable as exc:
        print(json.dumps({{"host": exc.host, "last_heard": exc.last_heard}}))
""")
    assert caught == {"host": "h01", "last_heard": error["detail"]["last_heard"]}
