"""Issue 14, defect 8: web pages cannot use the gateway behind its user's back (CSRF, DNS rebinding)."""

from __future__ import annotations

import aiohttp
import pytest

from aiogenomix.gateway import GatewayConfig
from aiogenomix.gateway._access import AccessPolicy

from ..conftest import TEST_TIME_SCALE
from ._raw_http import exchange_once

MOVE = "/module/demo/send/GotoPosition?input=%7B%22posRef%22:0.5%7D"


async def position(http: aiohttp.ClientSession) -> float:
    async with http.get("/module/demo/read/Mobile") as reply:
        return float((await reply.json())["Mobile"]["position"])


@pytest.fixture
async def demo(http: aiohttp.ClientSession) -> aiohttp.ClientSession:
    async with http.get("/load/demo") as reply:
        assert reply.status == 200
    return http


@pytest.mark.parametrize("headers", [
    {"Host": "attacker.example:8080"},                                          # DNS rebinding
    {"Origin": "http://attacker.example"},                                      # a script's fetch
    {"Origin": "null"},                                                         # a sandboxed frame
    {"Sec-Fetch-Site": "cross-site", "Sec-Fetch-Mode": "no-cors"},              # <img src=...>
    {"Sec-Fetch-Site": "cross-site", "Sec-Fetch-Mode": "navigate"},             # a link
    {"Sec-Fetch-Site": "same-site", "Sec-Fetch-Mode": "no-cors"},               # another port of localhost
])
async def test_a_foreign_page_cannot_move_the_robot(demo: aiohttp.ClientSession, headers: dict[str, str]) -> None:
    async with demo.get(MOVE, headers=headers) as reply:
        assert reply.status == 403
        body = await reply.json()
        assert body["ex"] == "::genomix::forbidden" and body["message"]
        assert reply.headers["X-Content-Type-Options"] == "nosniff"
    assert await position(demo) == 0.0
    async with demo.get("/module/demo/status/0") as reply:
        assert reply.status == 404                                              # no request was made


async def test_programs_and_the_gateways_own_pages_are_served(demo: aiohttp.ClientSession, gateway: str) -> None:
    own = gateway.rstrip("/")
    port = own.rsplit(":", 1)[1]
    for headers in ({}, {"Origin": own, "Sec-Fetch-Site": "same-origin"}, {"Host": f"localhost:{port}"},
                    {"Host": f"[::1]:{port}"}):
        async with demo.get("/module/demo/read/Mobile", headers=headers) as reply:
            assert reply.status == 200, headers
    async with demo.get("/console", headers={"Sec-Fetch-Site": "cross-site", "Sec-Fetch-Mode": "navigate"}) as page:
        assert page.status == 200                                               # a link to the console shows it
        policy = page.headers["Content-Security-Policy"]
        assert "default-src 'none'" in policy and "script-src 'self' 'sha256-" in policy and "unsafe" not in policy
        assert page.headers["X-Content-Type-Options"] == "nosniff"
    async with demo.get("/no/such/thing") as missing:
        assert missing.status == 404 and missing.headers["X-Content-Type-Options"] == "nosniff"


class TestAllowedByTheOperator:
    @pytest.fixture
    def gateway_config(self) -> GatewayConfig:
        return GatewayConfig.of(port=0, time_scale=TEST_TIME_SCALE, audio_socket_port=0, token="s3cret",
                             allowed_hosts=["robot.lab"], allowed_origins=["https://notebooks.lab"])

    async def test_named_hosts_and_origins_pass_and_the_rest_learns_nothing(self, http: aiohttp.ClientSession) -> None:
        auth = {"Authorization": "Bearer s3cret"}
        async with http.get("/load/demo", headers=auth) as reply:
            assert reply.status == 200
        async with http.get("/module/demo/read/Mobile", headers={"Host": "robot.lab:8080", **auth}) as reply:
            assert reply.status == 200
        async with http.get("/module/demo/read/Mobile",
                            headers={"Origin": "https://notebooks.lab", **auth}) as reply:
            assert reply.status == 200
            assert reply.headers["Access-Control-Allow-Origin"] == "https://notebooks.lab"
        # Refused before authentication: a foreign page does not even learn that a token is needed.
        async with http.get("/module/demo/read/Mobile", headers={"Origin": "https://elsewhere.lab"}) as reply:
            assert reply.status == 403


async def test_odd_header_bytes_are_refused_readably(demo: aiohttp.ClientSession) -> None:
    # Found by the fuzzer: a header that is not UTF-8 once made the refusal itself fail (HTTP 500).
    for headers in ({"Origin": "\x80"}, {"Host": "h\xe9llo"}):
        async with demo.get("/", headers=headers) as reply:
            assert reply.status == 403 and (await reply.json())["message"]


def test_host_verdicts_are_remembered_and_a_flood_of_names_stays_bounded() -> None:
    policy = AccessPolicy(allowed_hosts=["robot.lab"])
    for _ in range(2):  # the second time from the remembered verdicts
        assert policy.host_allowed("127.0.0.1:8080") and policy.host_allowed("[::1]:8080")
        assert policy.host_allowed("Robot.Lab:80") and policy.host_allowed("a.localhost")
        assert not policy.host_allowed("attacker.example:8080") and not policy.host_allowed("127.0.0.1.evil")
    for i in range(3000):  # names chosen by a client: each refused, none kept for ever
        assert not policy.host_allowed(f"attacker-{i}.example")
    assert len(policy._verdicts) <= 256
    assert policy.host_allowed("127.0.0.1:8080") and not policy.host_allowed("attacker-1.example")


async def test_every_kind_of_reply_forbids_content_sniffing(demo: aiohttp.ClientSession, gateway: str) -> None:
    # The header comes with the headers every reply starts from: each way of replying is checked.
    paths = ["/", "/version", "/console/login", "/module/demo/info", "/module/demo/read/Mobile",
             "/module/demo/read/Mobile?format=binary", "/module/demo/send/GetSpeed", "/module/demo/status/99",
             "/module/demo/read/Mobile?format=xml", "/no/such/thing", "/openapi.json"]
    for path in paths:
        async with demo.get(path) as reply:
            assert reply.headers.get("X-Content-Type-Options") == "nosniff", path
    async with demo.post("/version") as reply:
        assert reply.status == 405 and reply.headers.get("X-Content-Type-Options") == "nosniff"
    async with demo.get("/session/listen", params={"s": "sniff"}) as stream:
        assert stream.headers.get("X-Content-Type-Options") == "nosniff"
    # Refused by the HTTP layer, which closes the connection.
    _, head, _ = await exchange_once(gateway, b"GET /version HTTP/1.1\r\nHost: \x01bad\r\nBroken header\r\n\r\n")
    assert b" 400 " in head.split(b"\r\n")[0] and b"X-Content-Type-Options: nosniff" in head
