"""Across hosts: a component host and the gateway in two network namespaces joined by a veth pair.

The namespaces, the link and its link-local addresses (169.254.77.0/30, never routed) exist only
for the test and are removed after it, whatever happened.  Root is needed to create them: the
test is skipped, saying why, where it cannot.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import shutil
import subprocess
import urllib.parse
from collections.abc import Iterator

import pytest

from ._processes import Process, start_component_host, start_gateway

HOST_ADDRESS = "169.254.77.1"
GATEWAY_ADDRESS = "169.254.77.2"


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, timeout=10)


@pytest.fixture
def namespaces() -> Iterator[tuple[str, str]]:
    """Two fresh network namespaces joined by a veth pair; yields their names."""
    if shutil.which("ip") is None:
        pytest.skip("the ip command (iproute2) is not installed: cannot create network namespaces")
    if os.geteuid() != 0:
        pytest.skip("creating network namespaces needs root")
    robot, workstation = f"agx{os.getpid()}r", f"agx{os.getpid()}w"
    try:
        _ip("netns", "add", robot)
    except subprocess.CalledProcessError as exc:
        pytest.skip(f"ip netns is unavailable here: {exc.stderr.decode().strip()}")
    try:
        _ip("netns", "add", workstation)
        # Created inside the namespaces: the link never touches the machine's own interfaces.
        _ip("-n", robot, "link", "add", "agxr", "type", "veth", "peer", "name", "agxw", "netns", workstation)
        _ip("-n", robot, "addr", "add", f"{HOST_ADDRESS}/30", "dev", "agxr")
        _ip("-n", workstation, "addr", "add", f"{GATEWAY_ADDRESS}/30", "dev", "agxw")
        for namespace, link in ((robot, "agxr"), (workstation, "agxw")):
            _ip("-n", namespace, "link", "set", "lo", "up")
            _ip("-n", namespace, "link", "set", link, "up")
        yield robot, workstation
    finally:
        # Deleting a namespace deletes its end of the link, and the pair with it.
        for namespace in (robot, workstation):
            with contextlib.suppress(subprocess.CalledProcessError):
                _ip("netns", "del", namespace)


async def _curl(namespace: str, url: str) -> object:
    """GET *url* with curl from inside *namespace* (the gateway's loopback is only there)."""
    process = await asyncio.create_subprocess_exec(
        "ip", "netns", "exec", namespace, "curl", "-s", "--max-time", "30", url,
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE,
    )
    out, err = await process.communicate()
    assert process.returncode == 0, err.decode()
    text = out.decode()
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


async def test_a_component_host_on_another_host(namespaces: tuple[str, str], started: list[Process]) -> None:
    if shutil.which("curl") is None:
        pytest.skip("curl is not installed")
    robot, workstation = namespaces
    endpoint = f"tcp/{HOST_ADDRESS}:7447"
    started.append(await start_component_host(["demo"], listen=endpoint, prefix=["ip", "netns", "exec", robot]))
    gateway, url = await start_gateway([endpoint], prefix=["ip", "netns", "exec", workstation])
    started.append(gateway)
    assert await _curl(workstation, f"{url}/load/demo") == "demo"
    info = await _curl(workstation, f"{url}/module/demo/info")
    assert info["component"] == "demo"  # type: ignore[index]
    goto = urllib.parse.quote(json.dumps({"posRef": 0.75}))
    assert await _curl(workstation, f"{url}/module/demo/send/GotoPosition?input={goto}") == {
        "id": "demo::0", "status": "sent"}
    assert await _curl(workstation, f"{url}/module/demo/wait/demo::0?timeout=30") == {
        "id": "demo::0", "status": "done", "output": {}}
    assert await _curl(workstation, f"{url}/module/demo/read/Mobile") == {"Mobile": {"position": 0.75, "speed": 0.0}}
