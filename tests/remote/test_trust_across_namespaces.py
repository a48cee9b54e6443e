"""A lab's deployment across two network namespaces: authenticated, isolated, with the robot's audio socket
reached from the workstation and a cut link that never serves old data as current.

Robot namespace: ``robot1`` (demo, bass) listens with Zenoh user/password authentication; ``robot2``
(countserver) connects to it.  Workstation namespace: the gateway, told robot1's endpoint and its own
credentials, and an outsider without them.  Heavy (several processes): run once, on the default Python.
"""

from __future__ import annotations

import asyncio
import json
import os
import pathlib
import re
import shutil
import time
import urllib.parse

import pytest

from ._namespaces import ROBOT_ADDRESS, curl, lab, python_in, run_in
from ._processes import Process, start_component_host, start_gateway

pytestmark = pytest.mark.skipif(os.environ.get("AIOGENOMIX_HEAVY") == "0",
                                reason="hosts in network namespaces: run once, on the default Python")

#: What an outsider on the workstation can do with robot1's endpoint: it prints its links and replies.
_OUTSIDER = """
import json, zenoh
config = zenoh.Config()
for key, value in (("scouting/multicast/enabled", "false"), ("scouting/gossip/enabled", "false"),
                   ("listen/endpoints", "[]"), ("connect/endpoints", json.dumps([{endpoint!r}])),
                   ("connect/timeout_ms", "2000"), ("connect/exit_on_failure", "false")):
    config.insert_json5(key, value)
if {credentials!r}:
    config.insert_json5("transport/auth/usrpwd", json.dumps({credentials!r}))
session = zenoh.open(config)  # a peer's open does not fail: it keeps trying in the background
links = [str(link.dst) for link in session.info.links()]
goto = json.dumps({{"service": "GotoPosition", "input": {{"posRef": -0.5}}, "gateway": "outsider"}})
replies = [str(reply.ok.key_expr) for reply in session.get("aiogenomix/**", payload=goto, timeout=2)
           if reply.ok is not None]
tokens = [str(reply.ok.key_expr) for reply in session.liveliness().get("aiogenomix/**", timeout=2)
          if reply.ok is not None]
session.close()
print(json.dumps({{"links": links, "replies": replies, "tokens": tokens}}))
"""

#: The README's read of the robot's 2015 socket: ten frames from the oldest, the reply's header as int32s.
_README_SOCKET_READ = "printf 'Read Port - N 10 - nfr 0\\nClose\\n' | nc {address} 8081 | od -An -td4 -N16"


def _credentials(folder: pathlib.Path) -> dict[str, pathlib.Path]:
    """Zenoh configuration files: robot1 checks a user list; robot2 and the gateway log in."""
    users = folder / "users.txt"
    users.write_text("robot2:r2-secret\ngateway:gw-secret\n")
    users.chmod(0o600)
    files = {
        "robot1": f'{{transport: {{auth: {{usrpwd: {{user: "robot1", password: "r1-secret", '
                  f'dictionary_file: "{users}"}}}}}}}}',
        "robot2": '{transport: {auth: {usrpwd: {user: "robot2", password: "r2-secret"}}}}',
        "gateway": '{transport: {auth: {usrpwd: {user: "gateway", password: "gw-secret"}}}}',
    }
    paths = {}
    for name, text in files.items():
        paths[name] = folder / f"{name}.json5"
        paths[name].write_text(text)
    return paths


def _sockets(listing: str, pid: int) -> list[tuple[str, str]]:
    """The (local, peer) addresses of the sockets of process *pid* in an ``ss -Htnp`` listing."""
    found = []
    for line in listing.splitlines():
        if f"pid={pid}," in line:
            fields = line.split()
            found.append((fields[3], fields[4]))
    return found


async def test_an_authenticated_isolated_deployment(tmp_path: pathlib.Path, started: list[Process]) -> None:
    if shutil.which("curl") is None or shutil.which("ss") is None:
        pytest.skip("curl and ss (iproute2) are needed")
    configs = _credentials(tmp_path)
    robot1_endpoint, robot2_endpoint = f"tcp/{ROBOT_ADDRESS}:7447", f"tcp/{ROBOT_ADDRESS}:7448"
    with lab() as net:
        ws = net.on_workstation()
        robot1 = await start_component_host(
            ["demo", "bass"], listen=robot1_endpoint, host_id="robot1", prefix=net.on_robot(),
            extra=["--zenoh-config", str(configs["robot1"]), "--audio-socket-host", ROBOT_ADDRESS,
                   "--audio-socket-port", "8081"])
        started.append(robot1)
        started.append(await start_component_host(
            ["countserver"], listen=robot2_endpoint, connect=[robot1_endpoint], host_id="robot2",
            prefix=net.on_robot(), extra=["--zenoh-config", str(configs["robot2"])]))
        gateway, url = await start_gateway([robot1_endpoint], prefix=ws,
                                           extra=["--zenoh-config", str(configs["gateway"]), "--zenoh-stale", "1"])
        started.append(gateway)
        port = url.rsplit(":", 1)[1]

        # 1. Authentication: the gateway, with its credentials, drives robot1's demo.
        assert await curl(ws, f"{url}/load/demo") == (200, "demo")
        goto = urllib.parse.quote(json.dumps({"posRef": 0.5}))
        assert (await curl(ws, f"{url}/module/demo/send/GotoPosition?input={goto}"))[0] == 200
        assert (await curl(ws, f"{url}/module/demo/wait/demo::0?timeout=30"))[1]["status"] == "done"  # type: ignore[index]
        # An outsider on the same network, without credentials or with wrong ones: no link, no reply, no token.
        for credentials in (None, {"user": "gateway", "password": "guess"}):
            seen = await python_in(ws, _OUTSIDER.format(endpoint=robot1_endpoint, credentials=credentials))
            assert seen == {"links": [], "replies": [], "tokens": []}, (credentials, seen)
        assert (await curl(ws, f"{url}/module/demo/read/Mobile"))[1] == {"Mobile": {"position": 0.5, "speed": 0.0}}

        # 2. Isolation: the gateway is linked to robot1 only (robot1 is linked to robot2, which listens on an
        # address the workstation reaches), and it listens on nothing but its HTTP port.
        status, index = await curl(ws, f"{url}/")
        assert index["zenoh"]["links"] == [robot1_endpoint]  # type: ignore[index]
        listening = _sockets(await run_in(ws, "ss", "-Hltnp"), gateway.pid)
        assert [local for local, _ in listening] == [f"127.0.0.1:{port}"], listening
        connected = {peer for local, peer in _sockets(await run_in(ws, "ss", "-Htnp"), gateway.pid)
                     if not local.endswith(f":{port}")}
        assert connected == {f"{ROBOT_ADDRESS}:7447"}, connected

        # 3. The robot's dedicated audio socket, reached from the workstation as the README says: the host
        # said where it listens when it started.
        assert any(re.search(rf"bass listen on {ROBOT_ADDRESS}:8081", line) for line in robot1.lines), robot1.lines
        assert await curl(ws, f"{url}/load/bass") == (200, "bass")
        assert (await curl(ws, f"{url}/module/bass/send/DedicatedSocket"))[1]["status"] == "sent"  # type: ignore[index]
        assert (await curl(ws, f"{url}/module/bass/send/Acquire"))[1]["status"] == "sent"  # type: ignore[index]
        # Until the port holds ten frames: the first publication of the gateway's copy that says so.
        await run_in(ws, "sh", "-c", f"curl -sN --max-time 30 {url}/module/bass/watch/Audio"
                                     " | grep -q -m1 -E '\"lastFrameIndex\":[1-9][0-9]'")
        header = await run_in(ws, "sh", "-c", _README_SOCKET_READ.format(address=ROBOT_ADDRESS))
        count, lost, next_low, next_high = (int(word) for word in header.split())
        # Ten frames from the oldest the robot's port holds (the frames before it, gone from the window, are lost).
        assert count == 10 and next_low + (next_high << 32) == lost + count, header

        # 4. A cut link: within the stale bound (1 s here) reads of robot1's ports are refused, not answered
        # with the last value; mended before Zenoh's lease (10 s) ends, everything goes on.
        net.cut()
        cut = time.monotonic()
        try:
            async with asyncio.timeout(8):
                while (reply := await curl(ws, f"{url}/module/demo/read/Mobile"))[0] == 200:
                    await asyncio.sleep(0.1)
            refused_after = time.monotonic() - cut
            assert reply[0] == 504 and reply[1]["ex"] == "::genom::remote_io", reply  # type: ignore[index]
            assert "not heard from" in reply[1]["message"], reply  # type: ignore[index]
            assert refused_after < 1 + 2.5, f"old data was served {refused_after:.1f} s after the cut"
        finally:
            net.cut(False)
        async with asyncio.timeout(15):
            while (reply := await curl(ws, f"{url}/module/demo/read/Mobile"))[0] != 200:
                await asyncio.sleep(0.1)
        assert reply[1] == {"Mobile": {"position": 0.5, "speed": 0.0}}
        assert (await curl(ws, f"{url}/module/bass/read/Audio"))[0] == 200
        for process in started:
            await process.end()
