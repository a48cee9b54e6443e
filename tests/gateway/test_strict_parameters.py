"""A query parameter an endpoint does not take is refused before anything runs: a bad URL never moves a robot.

Over real sockets (aiohttp's client, and raw bytes where a client library
would tidy the URL): the flattened input an OpenAPI generator builds, a typo,
a repeated input, and one unknown parameter on every endpoint.
"""

from __future__ import annotations

import json
from typing import Any

import aiohttp
import pytest

from aiogenomix.gateway._parameters import ENDPOINT_PARAMETERS
from tests.gateway._raw_http import Connection


async def _refusal(http: aiohttp.ClientSession, url: str) -> dict[str, Any]:
    async with http.get(url) as reply:
        assert reply.status == 400, await reply.text()
        body: dict[str, Any] = await reply.json()
    assert body["ex"] == "::genomix::bad_parameter"
    return body


async def _mobile(http: aiohttp.ClientSession) -> dict[str, float]:
    async with http.get("/module/demo/read/Mobile") as reply:
        data: dict[str, float] = (await reply.json())["Mobile"]
        return data


@pytest.mark.parametrize("query", [
    "posRef=0.7",                                 # the flattened form of an OpenAPI SDK
    "inptu=%7B%22posRef%22:0.7%7D",               # a typo
    "input=%7B%22posRef%22:0.7%7D&input=%7B%22posRef%22:0.1%7D",  # which one?
    "input=%7B%22posRef%22:0.7%7D&argv=-i",       # argv is a load parameter
])
async def test_a_malformed_send_is_refused_and_nothing_moves(http: aiohttp.ClientSession, query: str) -> None:
    await http.get("/load/demo")
    before = await _mobile(http)
    body = await _refusal(http, f"/module/demo/send/GotoPosition?s=t&{query}")
    assert "input" in body["message"] and body["detail"]["takes"] == ["input", "oneway", "s"]
    if "posRef=" in query:
        assert 'input={"posRef":0.7}' in body["message"]  # says how to send it
    # Nothing was sent: no request id was used, and the robot is where it was.
    async with http.get("/module/demo/status/demo::0") as reply:
        assert reply.status == 404
    assert await _mobile(http) == before
    async with http.get("/module/demo/send/GotoPosition?s=t&input=%7B%22posRef%22:0.7%7D") as reply:
        assert (await reply.json())["id"] == "demo::0"  # the first id, unused by the refusals


async def test_the_head_does_not_turn_on_a_flattened_target(http: aiohttp.ClientSession) -> None:
    await http.get("/load/kemar")
    async with http.get("/module/kemar/read/currentState") as reply:
        before = await reply.json()
    body = await _refusal(http, "/module/kemar/send/MoveAbsolutePosition?target=20")
    assert "'target'" in body["message"]
    async with http.get("/module/kemar/status/0") as reply:
        assert reply.status == 404
    async with http.get("/module/kemar/read/currentState") as reply:
        assert await reply.json() == before


#: One URL per endpoint, each with the parameters it needs.
ENDPOINTS = {
    "/": "/",
    "/version": "/version",
    "/console": "/console",
    "/console/auth": "/console/auth",
    "/console/login": "/console/login",
    "/console/plots.js": "/console/plots.js",
    "/console/uPlot.iife.min.js": "/console/uPlot.iife.min.js",
    "/console/uPlot.min.css": "/console/uPlot.min.css",
    "/favicon.ico": "/favicon.ico",
    "/openapi.json": "/openapi.json",
    "/docs": "/docs",
    "/docs/swagger-ui-bundle.js": "/docs/swagger-ui-bundle.js",
    "/docs/swagger-ui.css": "/docs/swagger-ui.css",
    "/session/start": "/session/start?s=p",
    "/session/stop": "/session/stop?s=p",
    "/session/listen": "/session/listen?s=p",
    "/load": "/load/demo",
    "/unload": "/unload/demo",
    "/usage": "/usage/demo",
    "/module/info": "/module/demo/info",
    "/module/send": "/module/demo/send/GetSpeed",
    "/module/status": "/module/demo/status/demo::0",
    "/module/wait": "/module/demo/wait/demo::0?timeout=0",
    "/module/abort": "/module/demo/abort/demo::0",
    "/module/clean": "/module/demo/clean/demo::0",
    "/module/read": "/module/demo/read/Mobile",
    "/module/watch": "/module/demo/watch/Mobile",
}


def test_every_endpoint_is_listed() -> None:
    assert set(ENDPOINTS) == set(ENDPOINT_PARAMETERS)


@pytest.mark.parametrize("endpoint", list(ENDPOINTS))
async def test_every_endpoint_refuses_a_parameter_it_does_not_take(
        http: aiohttp.ClientSession, endpoint: str) -> None:
    await http.get("/load/demo")
    async with http.get("/module/demo/send/GetSpeed") as reply:  # demo::0, ended: status, wait, clean
        assert reply.status == 200
    url = ENDPOINTS[endpoint]
    body = await _refusal(http, url + ("&" if "?" in url else "?") + "bogus=1")
    assert body["detail"]["unknown"] == ["bogus"]
    assert body["detail"]["takes"] == sorted(ENDPOINT_PARAMETERS[endpoint] | {"s"})
    # Nothing happened: the module is still loaded, its request still there, no session made.
    async with http.get("/") as reply:
        state = await reply.json()
    assert state["loaded"] == {"demo": "demo"} and state["sessions"] == 0
    async with http.get("/module/demo/status/demo::0") as reply:
        assert (await reply.json())["status"] == "done"


async def test_a_cache_buster_is_taken_everywhere(http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo?_=1732550000000")
    async with http.get("/module/demo/send/GotoPosition?input=%7B%22posRef%22:0.25%7D&_=1") as reply:
        assert (await reply.json())["status"] == "sent"
    async with http.get("/module/demo/wait/demo::0?_=2") as reply:
        assert (await reply.json())["status"] == "done"
    assert (await _mobile(http))["position"] == 0.25


async def test_repeatable_argv_and_a_valueless_oneway_still_work(http: aiohttp.ClientSession) -> None:
    async with http.get("/load/demo?argv=-i&argv=demo2") as reply:
        assert await reply.text() == "demo2"
    async with http.get("/module/demo2/send/GotoPosition?input=%7B%22posRef%22:0.5%7D&oneway") as reply:
        assert reply.status == 200


async def test_a_plain_read_with_an_unknown_parameter_is_refused_by_the_routes(gateway: str) -> None:
    # Raw bytes: the read the connection answers itself when plain; with an unknown parameter
    # the door refuses it, and the refusal is the routes'.
    connection = await Connection.open(gateway)
    try:
        for path in ("/load/demo", "/module/demo/read/Mobile?since=0&bogus", "/module/demo/read/Mobile"):
            connection.writer.write(connection.request(path))
        replies = [(status, body) for status, _, body in [await connection.reply() for _ in range(3)]]
    finally:
        await connection.close()
    assert replies[0] == (200, b"demo")
    assert replies[1][0] == 400 and json.loads(replies[1][1])["detail"]["unknown"] == ["bogus"]
    assert replies[2][0] == 200 and set(json.loads(replies[2][1])) == {"Mobile"}
