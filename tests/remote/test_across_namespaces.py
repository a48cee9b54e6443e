"""Across hosts: a component host and the gateway in two network namespaces joined by a veth pair."""

from __future__ import annotations

import json
import shutil
import urllib.parse

import pytest

from ._namespaces import ROBOT_ADDRESS, curl, lab
from ._processes import Process, start_component_host, start_gateway


async def test_a_component_host_on_another_host(started: list[Process]) -> None:
    if shutil.which("curl") is None:
        pytest.skip("curl is not installed")
    with lab() as net:
        endpoint = f"tcp/{ROBOT_ADDRESS}:7447"
        started.append(await start_component_host(["demo"], listen=endpoint, prefix=net.on_robot()))
        gateway, url = await start_gateway([endpoint], prefix=net.on_workstation())
        started.append(gateway)
        ws = net.on_workstation()
        assert await curl(ws, f"{url}/load/demo") == (200, "demo")
        status, info = await curl(ws, f"{url}/module/demo/info")
        assert info["component"] == "demo"  # type: ignore[index]
        goto = urllib.parse.quote(json.dumps({"posRef": 0.75}))
        assert await curl(ws, f"{url}/module/demo/send/GotoPosition?input={goto}") == (
            200, {"id": "demo::0", "status": "sent"})
        assert await curl(ws, f"{url}/module/demo/wait/demo::0?timeout=30") == (
            200, {"id": "demo::0", "status": "done", "output": {}})
        assert await curl(ws, f"{url}/module/demo/read/Mobile") == (200, {"Mobile": {"position": 0.75, "speed": 0.0}})
        # The processes end before the namespaces go.
        for process in started:
            await process.end()
