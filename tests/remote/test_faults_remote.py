"""Faults of a component host: killed during an activity, frozen (as behind a cut network), and back again."""

from __future__ import annotations

import asyncio
import json
import signal
import sys
import time
import urllib.parse

import aiohttp

from tests.conftest import RawEventStream

from ._processes import Process, free_port, start_component_host, start_gateway, start_host_and_gateway


async def _get(http: aiohttp.ClientSession, path: str) -> tuple[int, dict]:
    async with http.get(path) as reply:
        return reply.status, await reply.json(content_type=None)


async def _next_event(events: RawEventStream, within: float = 30.0) -> tuple[str, str | None]:
    async with asyncio.timeout(within):
        while True:
            try:
                return await events.next_event()
            except TimeoutError:
                continue  # RawEventStream gives up after 10 s of silence; keep listening


async def test_a_killed_host_ends_its_requests_once_and_is_loaded_again_when_it_returns(started: list[Process]) -> None:
    # Real time: the move lasts seconds, and is still running when the host dies.
    host, url, endpoint = await start_host_and_gateway(started, ["demo"], extra=["--time-scale", "1"])
    async with aiohttp.ClientSession(base_url=url) as http:
        session = (await (await http.get("/session/start?s=")).text()).strip()
        events = await RawEventStream.open(url, session)
        try:
            assert (await http.get(f"/load/demo?s={session}")).status == 200
            move = urllib.parse.quote(json.dumps({"posRef": 0.9}))
            status, sent = await _get(http, f"/module/demo/send/GotoPosition?s={session}&input={move}")
            assert sent == {"id": "demo::0", "status": "sent"}
            assert await _next_event(events) == ("request", '{"id":"demo::0","status":"sent"}')
            waiting = asyncio.ensure_future(_get(http, "/module/demo/wait/demo::0?timeout=60"))

            killed = time.monotonic()
            host.kill(signal.SIGKILL)
            name, data = await _next_event(events)
            assert name == "request"
            ended = json.loads(data or "")
            assert ended["id"] == "demo::0" and ended["status"] == "error"
            assert ended["exception"]["ex"] == "::genom::remote_io"
            assert "demo" in ended["exception"]["detail"]["what"]
            assert await _next_event(events) == ("unload", '"demo"')  # once: no second end of demo::0
            noticed = time.monotonic() - killed
            assert noticed < 10, f"the death was noticed after {noticed:.1f} s"
            # The wait gets the request's end; or, when it reached the gateway only after the host was known
            # gone (a busy machine), the refusal that names the host: never a wait that hangs.
            status, waited = await waiting
            if status == 200:
                assert waited == ended
            else:
                assert (status, waited["ex"], waited["detail"]["host"]) == (503, "::genom::remote_io", "robot"), waited
            # Not an unknown name: its host is gone, and may come back.
            status, error = await _get(http, "/module/demo/info")
            assert (status, error["ex"], error["detail"]["host"]) == (503, "::genom::remote_io", "robot"), error
            assert "demo ran on component host robot" in error["message"] and "last heard" in error["message"]
            assert error["detail"]["last_heard"].endswith("Z")

            # A new host on the same endpoint and with the same host id: the gateway connects again, loads demo
            # again under its name, and says so to every session.
            host2 = await start_component_host(["demo"], listen=endpoint, extra=["--time-scale", "1"])
            started.append(host2)
            assert await _next_event(events) == ("offered", '{"name":"demo","host":"robot","loaded":"demo"}')
            status, sent = await _get(http, f"/module/demo/send/GetSpeed?s={session}")
            assert sent["status"] == "done"
            async with http.get(f"/load/demo?s={session}") as reply:
                assert reply.status == 200  # the instance loaded again: a load returns it
            # It is the new host's demo: when that host stops, the gateway unloads it.
            host2.kill(signal.SIGTERM)
            while (event := await _next_event(events)) != ("unload", '"demo"'):
                assert event[0] == "request", event
        finally:
            events.close()


async def test_a_frozen_host_gives_clear_errors_in_bounded_time(started: list[Process]) -> None:
    host, url, _ = await start_host_and_gateway(started, ["demo"], gateway_extra=["--zenoh-timeout", "1"])
    async with aiohttp.ClientSession(base_url=url) as http:
        assert (await http.get("/load/demo")).status == 200
        host.kill(signal.SIGSTOP)  # no answer, no reset: what a cut network looks like
        try:
            began = time.monotonic()
            status, error = await _get(http, "/module/demo/send/GetSpeed")
            took = time.monotonic() - began
            assert status == 504 and error["ex"] == "::genom::remote_io", error
            assert "no answer" in error["message"]
            assert took < 2 * 1 + 2.0 + 2.0, f"the send failed after {took:.1f} s"
            # Not heard from for longer than the stale bound (2 s): its data is not served as current.
            status, error = await _get(http, "/module/demo/read/Mobile")
            assert status == 504 and error["ex"] == "::genom::remote_io", error
            assert "not heard from" in error["message"] and "robot" in error["message"]
            status, error = await _get(http, "/module/demo/send/GetSpeed")
            assert status == 504 and "not heard from" in error["message"], error  # refused at once
        finally:
            host.kill(signal.SIGCONT)
        # Heard from again (its next heartbeat): its data is current again, and it takes requests.
        async with asyncio.timeout(10):
            while (await _get(http, "/module/demo/read/Mobile"))[0] != 200:
                await asyncio.sleep(0.05)
        status, sent = await _get(http, "/module/demo/send/GetSpeed")
        assert status == 200 and sent["status"] == "done"


async def test_a_gateway_started_before_its_host_finds_it_when_it_comes(started: list[Process]) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    gateway, url = await start_gateway([endpoint])  # nobody listens there yet: the gateway starts anyway
    started.append(gateway)
    async with aiohttp.ClientSession(base_url=url) as http:
        session = (await (await http.get("/session/start?s=")).text()).strip()
        events = await RawEventStream.open(url, session)
        try:
            started.append(await start_component_host(["demo"], listen=endpoint))
            # The gateway tells every session when a host offers an instance.
            assert await _next_event(events) == ("offered", '{"name":"demo","host":"robot","loaded":null}')
        finally:
            events.close()
        async with http.get("/load/demo") as reply:
            assert (reply.status, await reply.text()) == (200, "demo")


async def test_a_malformed_endpoint_is_one_line_and_status_1() -> None:
    for command in (["-m", "aiogenomix.gateway", "--port", "0", "--zenoh-connect", "tcp/robot"],
                    ["-m", "aiogenomix.remote._host_main", "demo", "--zenoh-listen", "tcp/robot:x"]):
        process = await asyncio.create_subprocess_exec(sys.executable, *command, stdout=asyncio.subprocess.PIPE,
                                                       stderr=asyncio.subprocess.PIPE)
        _, err = await asyncio.wait_for(process.communicate(), 60)
        assert process.returncode == 1
        assert "is not a Zenoh endpoint: write PROTOCOL/ADDRESS:PORT" in err.decode().splitlines()[-1]
