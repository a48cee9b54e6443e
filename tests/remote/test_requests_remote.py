"""A remote ``demo`` through the gateway, over the public wire: every request endpoint as for a local one."""

from __future__ import annotations

import asyncio
import json
import subprocess
import sys
import urllib.parse

import aiohttp

from aiogenomix.clients import aconnect, connect
from tests.clients.test_figure_4_3 import figure_4_3_session
from tests.conftest import RawEventStream

from ._processes import Process, start_gateway


def _input(value: object) -> str:
    return urllib.parse.quote(json.dumps(value))


async def _get(http: aiohttp.ClientSession, path: str) -> tuple[int, object]:
    async with http.get(path) as reply:
        return reply.status, await reply.json(content_type=None)


async def test_figure_4_3_with_the_python_client(demo_rig: tuple[str, Process, str]) -> None:
    url = demo_rig[0]
    # The sync client runs on its own thread: the gateway is another process.
    await asyncio.to_thread(figure_4_3_session, url)
    async with aconnect(url) as client:
        demo = await client.load("demo")
        assert await demo.GotoPosition(0.25) is None
        assert await demo.Mobile() == {"position": 0.25, "speed": 0.0}


async def test_every_request_endpoint_over_http(demo_rig: tuple[str, Process, str],
                                                 http_rig: aiohttp.ClientSession) -> None:
    url, http = demo_rig[0], http_rig
    session = (await (await http.get("/session/start?s=")).text()).strip()
    events = await RawEventStream.open(url, session)
    try:
        async with http.get(f"/load/demo?s={session}") as reply:
            assert (reply.status, await reply.text()) == (200, "demo")
        status, info = await _get(http, "/module/demo/info")
        assert status == 200 and info["component"] == "demo" and info["name"] == "demo"  # type: ignore[index]
        assert "GotoPosition" in [s["name"] for s in info["services"]]  # type: ignore[index]

        status, sent = await _get(http, f"/module/demo/send/GotoPosition?s={session}&input={_input({'posRef': 0.5})}")
        assert (status, sent) == (200, {"id": "demo::0", "status": "sent"})
        assert await events.next_event() == ("request", '{"id":"demo::0","status":"sent"}')
        assert await _get(http, "/module/demo/wait/demo::0?timeout=30") == (
            200, {"id": "demo::0", "status": "done", "output": {}})
        assert await events.next_event() == ("request", '{"id":"demo::0","status":"done","output":{}}')
        assert await _get(http, "/module/demo/status/0") == (200, {"id": "demo::0", "status": "done", "output": {}})
        assert await _get(http, "/module/demo/read/Mobile") == (200, {"Mobile": {"position": 0.5, "speed": 0.0}})

        # A refusal by validate is a request that ends in error, with the component's exception.
        status, refused = await _get(http, f"/module/demo/send/GotoPosition?s={session}&input={_input({'posRef': 2})}")
        assert status == 200 and refused == {"id": "demo::1", "status": "error", "exception": {
            "ex": "::demo::TOO_FAR_AWAY", "detail": {"overshoot": 1.0}}}
        assert (await events.next_event())[0] == "request"

        # Errors are the gateway's own, with their statuses.
        status, error = await _get(http, "/module/demo/send/Nope")
        assert status == 404 and error["ex"] == "::genom::no_such_service"  # type: ignore[index]
        status, error = await _get(http, f"/module/demo/send/GotoPosition?input={_input({'posRef': 'far'})}")
        assert status == 400 and error["ex"] == "::genom::serialization"  # type: ignore[index]
        status, error = await _get(http, "/module/demo/status/demo::7")
        assert status == 404 and error["ex"] == "::genomix::no_such_request"  # type: ignore[index]

        # Abort a long move; clean frees the id.
        status, sent = await _get(http, f"/module/demo/send/MoveDistance?s={session}&input={_input({'distRef': -1.4})}")
        assert sent == {"id": "demo::2", "status": "sent"}
        assert await events.next_event() == ("request", '{"id":"demo::2","status":"sent"}')
        status, aborted = await _get(http, "/module/demo/abort/demo::2")
        assert status == 200 and aborted["status"] == "error"  # type: ignore[index]
        assert aborted["exception"]["ex"] == "::genom::interrupted"  # type: ignore[index]
        name, data = await events.next_event()
        assert name == "request" and json.loads(data or "")["id"] == "demo::2"
        status, running = await _get(http, "/module/demo/clean/demo::2")
        assert status == 200
        assert (await _get(http, "/module/demo/status/demo::2"))[0] == 404

        # Oneway: no id to track, no event; the status of the requests of others is unchanged.
        status, oneway = await _get(http, f"/module/demo/send/GotoPosition?oneway&input={_input({'posRef': 0})}")
        assert status == 200 and oneway["status"] in ("sent", "done")  # type: ignore[index]

        # The standard services: genom_state lists the component's task.
        status, state = await _get(http, "/module/demo/read/genom_state")
        assert status == 200 and state["genom_state"]["digest"] == "demo"  # type: ignore[index]
        status, error = await _get(http, "/module/demo/read/Nope")
        assert status == 404 and error["ex"] == "::genom::no_such_outport"  # type: ignore[index]
        # The OpenAPI description lists the remote module's services.
        status, document = await _get(http, "/openapi.json")
        assert "/module/demo/send/GotoPosition" in document["paths"]  # type: ignore[index]
    finally:
        events.close()


async def test_a_name_runs_in_the_gateway_only_when_the_gateway_was_told_so(demo_rig: tuple[str, Process, str],
                                                                            started: list[Process]) -> None:
    # countclient is offered by no host: a gateway with remote components never runs it by itself.
    async with aiohttp.ClientSession(base_url=demo_rig[0]) as http:
        status, error = await _get(http, "/load/countclient")
        assert status == 404 and error["ex"] == "::genomix::no_such_module"  # type: ignore[index]
        assert "--local countclient" in error["message"]  # type: ignore[index]
        assert "countclient" not in (await _get(http, "/"))[1]["available"]  # type: ignore[index]
    gateway, url = await start_gateway([demo_rig[2]], extra=["--local", "countclient"])
    started.append(gateway)
    with connect(url) as client:
        countclient = client.load("countclient")
        assert "connect_port" in dir(countclient)
    async with aiohttp.ClientSession(base_url=url) as http:
        async with http.get("/load/demo") as reply:
            assert reply.status == 200
            assert json.loads(reply.headers["Aiogenomix-Where"])["host"] == "robot"
        index = (await _get(http, "/"))[1]
        assert index["where"]["countclient"] == {  # type: ignore[index]
            "runs": "here", "component": "countclient", "version": "1.0"}
        assert index["where"]["demo"]["runs"] == "remote"  # type: ignore[index]
        assert index["where"]["demo"]["endpoints"] == [demo_rig[2]]  # type: ignore[index]


async def test_token_and_allow_list_apply_to_remote_components(demo_rig: tuple[str, Process, str],
                                                                started: list[Process]) -> None:
    endpoint = demo_rig[2]
    gateway, url = await start_gateway([endpoint], extra=["--components", "countserver", "--token", "t0k"])
    started.append(gateway)
    async with aiohttp.ClientSession(base_url=url) as http:
        async with http.get("/load/countserver") as reply:
            assert reply.status == 401
        authorized = {"Authorization": "Bearer t0k"}
        async with http.get("/load/demo", headers=authorized) as reply:
            # demo is offered on Zenoh, but not in this gateway's allow-list.
            assert reply.status == 404 and (await reply.json())["ex"] == "::genomix::no_such_module"
        async with http.get("/load/countserver", headers=authorized) as reply:
            assert (reply.status, await reply.text()) == (200, "countserver")
        async with http.get("/", headers=authorized) as reply:
            assert "countserver" in (await reply.json())["offered"]


async def test_remote_instances_count_towards_the_instance_cap(demo_rig: tuple[str, Process, str],
                                                                 started: list[Process]) -> None:
    gateway, url = await start_gateway([demo_rig[2]], extra=["--max-instances", "1"])
    started.append(gateway)

    async def load(name: str) -> tuple[int, str]:
        async with http.get(f"/load/{name}") as reply:
            return reply.status, await reply.text()

    async with aiohttp.ClientSession(base_url=url) as http:
        assert await load("demo") == (200, "demo")
        status, text = await load("countserver")
        assert (status, json.loads(text)["ex"]) == (429, "::genomix::too_many_instances")
        assert await load("demo") == (200, "demo")  # the loaded proxy is returned, not counted again
        await http.get("/unload/demo")
        assert await load("countserver") == (200, "countserver")


def test_zenoh_is_not_imported_unless_asked_for() -> None:
    check = ("import sys, asyncio\n"
             "from aiogenomix.gateway import GatewayConfig, create_app\n"
             "create_app(GatewayConfig.of(port=0))\n"
             "assert 'zenoh' not in sys.modules, 'zenoh was imported'\n")
    done = subprocess.run([sys.executable, "-c", check], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr


def test_a_component_host_carries_no_http_gateway() -> None:
    # Beside the import-linter contract: what a robot's process really imports, its components loaded.
    check = ("import asyncio, sys\n"
             "import aiogenomix.remote, aiogenomix.remote._host_main\n"
             "from aiogenomix.components.core import ComponentHost\n"
             "async def main():\n"
             "    async with ComponentHost() as host:\n"
             "        for name in ('demo', 'kemar', 'capture', 'bass'):\n"
             "            await host.load(name)\n"
             "asyncio.run(main())\n"
             "web = sorted(m for m in sys.modules\n"
             "             if m.startswith('aiogenomix.gateway') or m.split('.')[0] == 'aiohttp')\n"
             "assert not web, web\n")
    done = subprocess.run([sys.executable, "-c", check], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
