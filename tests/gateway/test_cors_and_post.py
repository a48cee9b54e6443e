"""Web apps of an allowed origin can use a gateway with a token; services take a typed JSON body by POST.

CORS headers on every reply to an allowed origin (refusals, errors, 401 and
event streams included), preflights answered before the token, a POST form of
``send`` that browsers must preflight, and Swagger UI served at ``/docs``.
"""

from __future__ import annotations

import json

import aiohttp
import pytest

from aiogenomix.gateway import GatewayConfig

TOKEN = "s3cret"
APP = "http://app.example:3000"
AUTH = {"Authorization": f"Bearer {TOKEN}"}


@pytest.fixture
def gateway_config() -> GatewayConfig:
    return GatewayConfig.of(port=0, audio_socket_port=0, token=TOKEN, allowed_origins=[APP])


async def test_a_preflight_is_answered_before_the_token(http: aiohttp.ClientSession) -> None:
    asked = {"Origin": APP, "Access-Control-Request-Method": "POST",
             "Access-Control-Request-Headers": "authorization, content-type"}
    async with http.options("/module/demo/send/GotoPosition", headers=asked) as reply:
        assert reply.status == 204
        assert reply.headers["Access-Control-Allow-Origin"] == APP
        assert "POST" in reply.headers["Access-Control-Allow-Methods"]
        allowed = reply.headers["Access-Control-Allow-Headers"].lower()
        assert "authorization" in allowed and "content-type" in allowed and "last-event-id" in allowed
    async with http.options("/module/demo/send/GotoPosition", headers=asked | {"Origin": "https://evil.example"}
                            ) as reply:
        assert reply.status == 403 and "Access-Control-Allow-Origin" not in reply.headers


async def test_every_reply_to_an_allowed_origin_is_readable(http: aiohttp.ClientSession) -> None:
    page = {"Origin": APP}
    async with http.get("/load/demo", headers=page) as reply:  # no token
        assert reply.status == 401 and reply.headers["Access-Control-Allow-Origin"] == APP
    async with http.get("/load/demo", headers=page | AUTH) as reply:
        assert reply.status == 200 and reply.headers["Access-Control-Allow-Origin"] == APP
    async with http.get("/module/demo/send/Nothing", headers=page | AUTH) as reply:  # an error
        assert reply.status == 404 and reply.headers["Access-Control-Allow-Origin"] == APP
    async with http.get("/module/demo/read/Mobile?bogus=1", headers=page | AUTH) as reply:  # a refusal
        assert reply.status == 400 and reply.headers["Access-Control-Allow-Origin"] == APP
    for standard in (True, False):
        stream = page | AUTH | ({"Accept": "text/event-stream"} if standard else {})
        async with http.get("/session/listen?s=web", headers=stream) as reply:
            assert reply.status == 200 and reply.headers["Access-Control-Allow-Origin"] == APP
        async with http.get("/module/demo/watch/Mobile", headers=stream) as reply:
            assert reply.status == 200 and reply.headers["Access-Control-Allow-Origin"] == APP
    async with http.get("/session/listen?s=web", headers=page | AUTH | {"Last-Event-ID": "end"}) as reply:
        assert reply.status == 204 and reply.headers["Access-Control-Allow-Origin"] == APP
    async with http.get("/version", headers=AUTH) as reply:  # a program: no CORS headers
        assert "Access-Control-Allow-Origin" not in reply.headers


async def test_a_service_takes_its_input_as_a_json_body(http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo", headers=AUTH)
    async with http.post("/module/demo/send/GotoPosition?s=p", json={"posRef": 0.5}, headers=AUTH) as reply:
        started = await reply.json()
        assert started["status"] == "sent"
    async with http.get(f"/module/demo/wait/{started['id']}", headers=AUTH) as reply:
        assert (await reply.json())["status"] == "done"
    async with http.get("/module/demo/read/Mobile", headers=AUTH) as reply:
        assert (await reply.json())["Mobile"]["position"] == 0.5
    async with http.post("/module/demo/send/GetSpeed", headers=AUTH) as reply:  # no body: no input
        assert (await reply.json())["output"] == {"speedRef": "::demo::SLOW"}


@pytest.mark.parametrize(("headers", "query", "body", "status", "ex"), [
    ({"Content-Type": "text/plain"}, "", b'{"posRef":0.7}', 415, "::genomix::unsupported_media_type"),
    ({}, "", b'{"posRef":0.7}', 415, "::genomix::unsupported_media_type"),  # a form's body, say
    ({"Content-Type": "application/json"}, "?input=%7B%7D", b'{"posRef":0.7}', 400, "::genomix::bad_parameter"),
    ({"Content-Type": "application/json"}, "", b'{"posRef":', 400, "::genom::serialization"),
    ({"Content-Type": "application/json"}, "", b'{"pos":0.7}', 400, "::genom::serialization"),
    ({"Content-Type": "application/json"}, "", b"null", 400, "::genom::serialization"),  # not the input model
    ({"Content-Type": "application/json"}, "", b"\xb2", 400, "::genom::serialization"),  # not UTF-8
])
async def test_a_bad_post_moves_nothing(http: aiohttp.ClientSession, headers: dict[str, str], query: str,
                                        body: bytes, status: int, ex: str) -> None:
    await http.get("/load/demo", headers=AUTH)
    async with http.post(f"/module/demo/send/GotoPosition{query}", data=body, headers=AUTH | headers) as reply:
        assert reply.status == status and (await reply.json())["ex"] == ex
    async with http.get("/module/demo/status/demo::0", headers=AUTH) as reply:
        assert reply.status == 404  # nothing was sent


async def test_head_never_acts_and_waits_are_bounded(http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo", headers=AUTH)
    async with http.head("/module/demo/send/GotoPosition?input=%7B%22posRef%22:0.5%7D", headers=AUTH) as reply:
        assert reply.status == 405
    async with http.head("/unload/demo", headers=AUTH) as reply:
        assert reply.status == 405
    async with http.get("/module/demo/read/Mobile", headers=AUTH) as reply:
        assert (await reply.json())["Mobile"]["position"] == 0.0
    await http.get("/module/demo/send/GetSpeed", headers=AUTH)
    async with http.get("/module/demo/wait/demo::0?timeout=3601", headers=AUTH) as reply:
        assert reply.status == 400 and "3600" in (await reply.json())["message"]


async def test_swagger_ui_is_served_by_the_gateway_without_the_token(http: aiohttp.ClientSession) -> None:
    async with http.get("/docs") as reply:
        assert reply.status == 200 and reply.content_type == "text/html"
        policy = reply.headers["Content-Security-Policy"]
        assert "script-src 'self' 'sha256-" in policy and "connect-src 'self'" in policy
        assert b'url: "/openapi.json"' in await reply.read()
    for asset, kind in (("swagger-ui-bundle.js", "application/javascript"), ("swagger-ui.css", "text/css")):
        async with http.get(f"/docs/{asset}") as reply:
            assert reply.status == 200 and reply.content_type == kind and len(await reply.read()) > 10_000
    async with http.get("/openapi.json") as reply:  # read before the token can be given; its operations need it
        assert json.loads(await reply.read())["security"] == [{"token": []}]
    async with http.get("/module/demo/info") as reply:
        assert reply.status == 401
