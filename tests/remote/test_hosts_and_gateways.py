"""Several hosts and several gateways on one Zenoh network: one name moves one robot, each gateway keeps its
own sessions, a vanished gateway's motions stop, and a restarting host is never replaced by a local copy.

Heavy (five processes): run once, on the default Python (``AIOGENOMIX_HEAVY=0`` skips them).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import time
import urllib.parse
from collections.abc import AsyncIterator

import aiohttp
import pytest

from tests.conftest import RawEventStream

from ._processes import Process, free_port, start_component_host, start_gateway, start_router

pytestmark = pytest.mark.skipif(os.environ.get("AIOGENOMIX_HEAVY") == "0",
                                reason="several hosts and gateways: run once, on the default Python")


async def _get(http: aiohttp.ClientSession, url: str) -> tuple[int, dict]:
    async with http.get(url) as reply:
        return reply.status, await reply.json(content_type=None)


async def _text(http: aiohttp.ClientSession, url: str) -> tuple[int, str]:
    async with http.get(url) as reply:
        return reply.status, await reply.text()


def _input(value: object) -> str:
    return urllib.parse.quote(json.dumps(value))


async def _heard(http: aiohttp.ClientSession, url: str, hosts: set[str]) -> None:
    """Return once the gateway at *url* hears every host of *hosts* (it lists them in ``/``).

    Each host heard is an ``offered`` event on the listen stream: ``/`` is read again at each.
    """
    session = (await _text(http, f"{url}/session/start?s="))[1].strip()
    stream = await RawEventStream.open(url, session)
    try:
        async with asyncio.timeout(30):
            while {run["host"] for run in (await _get(http, f"{url}/"))[1]["zenoh"]["hosts"]} != hosts:
                with contextlib.suppress(TimeoutError):  # the stream gives up after 10 s of silence: listen again
                    await stream.next_event()
    finally:
        stream.close()


async def _request_event(stream: RawEventStream) -> str | None:
    """The data of the stream's next ``request`` event (an ``offered`` one, of a host heard, may come first)."""
    while True:
        name, data = await stream.next_event()
        if name == "request":
            return data
        assert name == "offered", (name, data)


async def _positions(http: aiohttp.ClientSession, url: str) -> AsyncIterator[dict]:
    """Each publication of demo's Mobile port, as the gateway at *url* streams it."""
    async with http.get(f"{url}/module/demo/watch/Mobile") as reply:
        async for line in reply.content:
            if line.startswith(b"data:"):
                yield json.loads(line[5:])["Mobile"]


async def test_one_name_two_hosts_two_gateways(started: list[Process]) -> None:
    # Real time: the dead-man check below needs a move that lasts seconds.
    endpoints = [f"tcp/127.0.0.1:{free_port()}" for _ in range(2)]
    robots = await asyncio.gather(*(start_component_host(names, listen=endpoint, host_id=f"robot{n}",
                                                         extra=["--time-scale", "1"])
                                    for n, (endpoint, names) in enumerate(zip(endpoints, (["demo", "kemar"], ["demo"]),
                                                                              strict=True), 1)))
    started.extend(robots)
    gateways = await asyncio.gather(start_gateway(endpoints), start_gateway(endpoints[:1]),
                                    start_gateway(endpoints[1:]))
    started.extend(process for process, _ in gateways)
    (both_process, both), (_, first), (_, second) = gateways
    async with aiohttp.ClientSession() as http:
        await _heard(http, both, {"robot1", "robot2"})
        # Two hosts offer demo: the gateway that sees both does not guess.
        status, error = await _get(http, f"{both}/load/demo")
        assert status == 409 and error["ex"] == "::genomix::ambiguous_module", error
        assert "robot1 (tcp/127.0.0.1:" in error["message"] and "robot2 (tcp/127.0.0.1:" in error["message"]
        assert "load demo@robot1 or demo@robot2" in error["message"]
        # Each is reached by its host's name, under a name of its own here.
        for name, argv, runs_on in (("demo@robot1", "", "robot1"), ("demo@robot2", "&argv=-i%20demo2", "robot2")):
            async with http.get(f"{both}/load/{name}?{argv}") as reply:
                assert reply.status == 200, await reply.text()
                assert json.loads(reply.headers["Aiogenomix-Where"])["host"] == runs_on
        where = (await _get(http, f"{both}/"))[1]["where"]
        assert (where["demo"]["host"], where["demo2"]["host"]) == ("robot1", "robot2")
        assert where["demo"]["endpoints"] == endpoints[:1] and where["demo"]["protocol"] == 2
        for url in (first, second):
            async with http.get(f"{url}/load/demo") as reply:  # one host each: no doubt
                assert (reply.status, await reply.text()) == (200, "demo")

        # Two sessions named s1, one per gateway.
        for url in (both, first):
            assert await _text(http, f"{url}/session/start?s=s1") == (200, "s1")
        streams = {url: await RawEventStream.open(url, "s1") for url in (both, first)}
        try:
            # One request moves one robot.
            goto = f"{both}/module/demo/send/GotoPosition?s=s1&input="
            status, sent = await _get(http, goto + _input({"posRef": 0.3}))
            assert sent == {"id": "demo::0", "status": "sent"}
            assert await _get(http, f"{both}/module/demo/wait/demo::0?timeout=60") == (
                200, {"id": "demo::0", "status": "done", "output": {}})
            # Another gateway hears robot1's last publication on its own link, maybe after this one heard the end.
            async with asyncio.timeout(30):
                async for mobile in _positions(http, first):
                    if mobile == {"position": 0.3, "speed": 0.0}:
                        break
            assert (await _get(http, f"{second}/module/demo/read/Mobile"))[1]["Mobile"]["position"] == 0.0
            assert (await _get(http, f"{both}/module/demo2/read/Mobile"))[1]["Mobile"]["position"] == 0.0

            # Each gateway's s1 hears its own requests only, and cannot see the other's.
            assert await _request_event(streams[both]) == '{"id":"demo::0","status":"sent"}'
            assert await _request_event(streams[both]) == '{"id":"demo::0","status":"done","output":{}}'
            status, error = await _get(http, f"{first}/module/demo/status/demo::0")
            assert status == 404 and error["ex"] == "::genomix::no_such_request", error
            slow = _input({"speedRef": "::demo::SLOW"})
            status, done = await _get(http, f"{first}/module/demo/send/SetSpeed?s=s1&input={slow}")
            assert done["status"] == "done"
            assert await _request_event(streams[first]) == json.dumps(done, separators=(",", ":"))
            status, mine = await _get(http, f"{both}/module/demo/send/GetSpeed?s=s1")
            assert await _request_event(streams[both]) == json.dumps(mine, separators=(",", ":"))

            # The gateway that started a motion dies: the robot stops within Zenoh's lease (here: at once,
            # its link closes), while another gateway watches.
            status, sent = await _get(http, goto + _input({"posRef": -0.9}))
            assert sent["status"] == "sent"
            # The head homes meanwhile (seconds of real time: it is still turning when the gateway dies).
            assert (await _text(http, f"{both}/load/kemar"))[0] == 200
            status, homing = await _get(http, f"{both}/module/kemar/send/Homing?s=s1")
            assert homing["status"] == "sent", homing
            # An activity that is no motion (it waits for the robot to cross a place it will never reach).
            monitor = f"{both}/module/demo/send/Monitor?s=s1&input={_input({'monitor': 0.95})}"
            status, watching = await _get(http, monitor)
            assert watching["status"] == "sent"
            async with asyncio.timeout(60):
                positions = _positions(http, first)
                async for mobile in positions:
                    if mobile["speed"] != 0.0:
                        break
                both_process.kill(signal.SIGKILL)
                killed = time.monotonic()
                async for mobile in positions:
                    if mobile["speed"] == 0.0:
                        break
                stopped_after = time.monotonic() - killed
            assert mobile["position"] > -0.8, mobile  # stopped on the way, far from the goal
            assert stopped_after < 10.0, f"the robot stopped {stopped_after:.1f} s after its gateway died"
            assert (await _get(http, f"{first}/module/demo/read/Mobile"))[1]["Mobile"] == mobile
            # The other robot never moved.
            assert (await _get(http, f"{second}/module/demo/read/Mobile"))[1]["Mobile"]["position"] == 0.0
            # The head stopped too, by the same switch: its request, now nobody's, says so to another gateway.
            assert (await _text(http, f"{first}/load/kemar"))[0] == 200
            status, homed = await _get(http, f"{first}/module/kemar/wait/{homing['id']}?timeout=30")
            assert homed["exception"] == {"ex": "::genom::interrupted", "detail": {"by": "gateway_gone"}}, homed
            assert time.monotonic() - killed < 10.0
            # What was no motion goes on, and belongs to no gateway now: another one may see it and end it.
            orphan = watching["id"]
            assert await _get(http, f"{first}/module/demo/status/{orphan}") == (200, watching)
            status, aborted = await _get(http, f"{first}/module/demo/abort/{orphan}")
            assert aborted["exception"] == {"ex": "::genom::interrupted", "detail": {"by": "abort"}}, aborted
        finally:
            for stream in streams.values():
                stream.close()


async def test_loads_raced_against_a_restarting_host_never_run_in_the_gateway(started: list[Process]) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    host = await start_component_host(["kemar"], listen=endpoint, host_id="robot1")
    started.append(host)
    gateway, url = await start_gateway([endpoint])
    started.append(gateway)
    async with aiohttp.ClientSession() as http:
        await _heard(http, url, {"robot1"})
        host.kill(signal.SIGKILL)
        # No event says that an offer of a name nobody loaded went: the host's gone when / says so.
        async with asyncio.timeout(30):
            while "kemar" in (await _get(http, f"{url}/"))[1]["offered"]:
                await asyncio.sleep(0.05)

        async def load(delay: float) -> tuple[int, dict | None]:
            await asyncio.sleep(delay)  # the race's stimulus: loads spread over the restart
            async with http.get(f"{url}/load/kemar") as reply:
                where = reply.headers.get("Aiogenomix-Where")
                return reply.status, json.loads(where) if where else None

        # Loads while the host restarts (they wait for it), then 20 over the 3 s after it offers kemar again.
        during = [asyncio.ensure_future(load(0.1 * n)) for n in range(5)]
        started.append(await start_component_host(["kemar"], listen=endpoint, host_id="robot1"))
        after = await asyncio.gather(*(load(0.15 * n) for n in range(20)))
        replies = [*await asyncio.gather(*during), *after]
    assert all(where is None or where["runs"] == "remote" for _, where in replies), replies
    assert [status for status, _ in after] == [200] * 20, after
    # A load while the host restarts waits for it: loaded there, or 504 if it did not come back in time.
    assert all((status, where is None) in ((200, False), (504, True)) for status, where in replies), replies
    async with aiohttp.ClientSession() as http:
        index = (await _get(http, f"{url}/"))[1]
    assert index["where"]["kemar"]["runs"] == "remote" and index["where"]["kemar"]["host"] == "robot1"


async def test_hosts_and_gateways_meet_at_a_router(tmp_path: pathlib.Path, started: list[Process]) -> None:
    router_endpoint = f"tcp/127.0.0.1:{free_port()}"
    started.append(await start_router(router_endpoint))
    # Both are Zenoh clients of the router, from Zenoh's own configuration file.
    client = tmp_path / "client.json5"
    client.write_text(f'{{mode: "client", connect: {{endpoints: ["{router_endpoint}"]}}}}')
    started.append(await start_component_host(["demo"], host_id="robot1", extra=["--zenoh-config", str(client)]))
    gateway, url = await start_gateway([], extra=["--zenoh-config", str(client)])
    started.append(gateway)
    async with aiohttp.ClientSession() as http:
        await _heard(http, url, {"robot1"})
        async with http.get(f"{url}/load/demo") as reply:
            assert reply.status == 200
            assert json.loads(reply.headers["Aiogenomix-Where"])["endpoints"] == [router_endpoint]
        status, sent = await _get(http, f"{url}/module/demo/send/GotoPosition?input={_input({'posRef': 0.2})}")
        assert sent["status"] == "sent"
        assert (await _get(http, f"{url}/module/demo/wait/demo::0?timeout=30"))[1]["status"] == "done"
        assert (await _get(http, f"{url}/"))[1]["zenoh"]["links"] == [router_endpoint]


def _certificates(folder: pathlib.Path) -> None:
    """A lab's certificate authority, and certificates it signs for robot1, the gateway and an intruder."""
    def openssl(*args: str) -> None:
        subprocess.run(["openssl", *args], cwd=folder, check=True, capture_output=True, timeout=30)

    openssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", "ca-key.pem", "-out", "ca.pem", "-days", "2",
            "-subj", "/CN=lab-ca")
    for name, usage in (("robot1", "serverAuth"), ("gateway", "clientAuth"), ("intruder", "clientAuth")):
        # rustls (Zenoh's TLS) takes X.509 v3 certificates only: the extensions make them v3.
        (folder / f"{name}.ext").write_text(f"subjectAltName=IP:127.0.0.1\nextendedKeyUsage={usage}\n")
        openssl("req", "-newkey", "rsa:2048", "-nodes", "-keyout", f"{name}-key.pem", "-out", f"{name}.csr",
                "-subj", f"/CN={name}")
        openssl("x509", "-req", "-in", f"{name}.csr", "-CA", "ca.pem", "-CAkey", "ca-key.pem", "-CAcreateserial",
                "-out", f"{name}.pem", "-days", "2", "-extfile", f"{name}.ext")


#: What the robot lets certificates named ``gateway`` do; everybody else may do nothing.
_ACCESS = """access_control: {
    enabled: true, default_permission: "deny",
    rules: [{id: "aiogenomix", permission: "allow", flows: ["ingress", "egress"], key_exprs: ["aiogenomix/**"],
             messages: ["put", "query", "reply", "declare_subscriber", "declare_queryable", "liveliness_token",
                        "liveliness_query", "declare_liveliness_subscriber"]}],
    subjects: [{id: "gateways", cert_common_names: ["gateway"]}],
    policies: [{rules: ["aiogenomix"], subjects: ["gateways"]}],
}"""

#: A session that connects with a certificate (or none) and says what it reaches.
_TLS_PEER = """
import json, sys, zenoh
config = zenoh.Config()
tls = {"root_ca_certificate": sys.argv[2] + "/ca.pem"}
if sys.argv[3]:
    tls |= {"connect_certificate": f"{sys.argv[2]}/{sys.argv[3]}.pem",
            "connect_private_key": f"{sys.argv[2]}/{sys.argv[3]}-key.pem", "enable_mtls": True}
for key, value in (("scouting/multicast/enabled", "false"), ("scouting/gossip/enabled", "false"),
                   ("listen/endpoints", "[]"), ("connect/endpoints", json.dumps([sys.argv[1]])),
                   ("connect/timeout_ms", "2000"), ("connect/exit_on_failure", "false"),
                   ("transport/link/tls", json.dumps(tls))):
    config.insert_json5(key, value)
session = zenoh.open(config)
links = [str(link.dst) for link in session.info.links()]
replies = [str(reply.ok.key_expr) for reply in session.get("aiogenomix/**", timeout=2) if reply.ok is not None]
session.close()
print(json.dumps({"links": links, "replies": replies}))
"""


async def test_mutual_tls_and_access_control_by_certificate(tmp_path: pathlib.Path, started: list[Process]) -> None:
    if shutil.which("openssl") is None:
        pytest.skip("openssl is not installed")
    _certificates(tmp_path)
    endpoint = f"tls/127.0.0.1:{free_port()}"
    (tmp_path / "robot1.json5").write_text(f"""{{
        transport: {{link: {{tls: {{root_ca_certificate: "{tmp_path}/ca.pem", enable_mtls: true,
            listen_certificate: "{tmp_path}/robot1.pem", listen_private_key: "{tmp_path}/robot1-key.pem"}}}}}},
        {_ACCESS}
    }}""")
    (tmp_path / "gateway.json5").write_text(f"""{{
        transport: {{link: {{tls: {{root_ca_certificate: "{tmp_path}/ca.pem", enable_mtls: true,
            connect_certificate: "{tmp_path}/gateway.pem", connect_private_key: "{tmp_path}/gateway-key.pem"}}}}}}
    }}""")
    started.append(await start_component_host(["demo"], listen=endpoint, host_id="robot1",
                                              extra=["--zenoh-config", str(tmp_path / "robot1.json5")]))
    gateway, url = await start_gateway([endpoint], extra=["--zenoh-config", str(tmp_path / "gateway.json5")])
    started.append(gateway)
    async with aiohttp.ClientSession() as http:
        await _heard(http, url, {"robot1"})
        async with http.get(f"{url}/load/demo") as reply:
            assert reply.status == 200
        status, done = await _get(http, f"{url}/module/demo/send/GetSpeed")
        assert done["status"] == "done", done
    # A certificate of the lab's authority but another name: linked (TLS is satisfied), refused everything.
    # No certificate at all: not even linked.
    for certificate, expected in (("intruder", ([endpoint], [])), ("", ([], []))):
        process = await asyncio.create_subprocess_exec(
            sys.executable, "-c", _TLS_PEER, endpoint, str(tmp_path), certificate,
            stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)
        out, err = await asyncio.wait_for(process.communicate(), 60)
        seen = json.loads(out.decode().splitlines()[-1])
        assert (seen["links"], seen["replies"]) == expected, (certificate, seen, err.decode()[-500:])
