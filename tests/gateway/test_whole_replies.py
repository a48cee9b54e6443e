"""JSON and text replies are written whole, with the bytes aiohttp would have written.

``json_reply`` and ``text_reply`` make a :class:`~aiogenomix.gateway._replies.Reply`,
aiohttp's ``Response`` that writes its head and body in one piece when nothing
in it is unusual, without aiohttp's header preparation.  These tests ask the
routes for the same replies both ways (written whole, and with the whole write
switched off, so that aiohttp prepares them) and compare them byte for byte but
for the ``Date``; and check that what only aiohttp's way does (``HEAD``,
HTTP/1.0, a connection that closes, a cookie) still goes its way.  Raw sockets,
on kept-alive connections as clients use them.
"""

from __future__ import annotations

import pytest
from aiohttp import web

from aiogenomix.gateway import GatewayConfig
from aiogenomix.gateway._replies import Reply, json_reply
from tests.gateway._raw_http import Connection, answered_ahead

PAGE = "https://notebooks.lab"


@pytest.fixture
def whole(monkeypatch: pytest.MonkeyPatch) -> list[bool]:
    """Whether each reply prepared was written whole (True) or by aiohttp."""
    return answered_ahead(monkeypatch, Reply, "_head")


@pytest.fixture
def gateway_config() -> GatewayConfig:
    """The gateway of :func:`connection` (``tests/gateway/conftest.py``), with a page allowed to call it."""
    return GatewayConfig.of(port=0, allowed_origins=[PAGE])


@pytest.mark.parametrize(("path", "headers"), [
    ("/version", ()),
    ("/module/demo/info", ()),
    ("/openapi.json", ()),
    ("/usage/demo", ()),
    ("/nowhere", ()),  # the router's 404, as the guard answers it
    ("/module/nobody/info", ()),  # 404, the guard's error reply
    ("/module/demo/status/0", ()),
    ("/module/demo/info?bad=1", ()),  # the door's refusal
    ("/version", (f"Origin: {PAGE}",)),  # with the CORS headers the guard adds
    ("/version", ("Origin: https://elsewhere.example",)),
])
async def test_a_reply_written_whole_is_aiohttps_byte_for_byte(
        connection: Connection, whole: list[bool], monkeypatch: pytest.MonkeyPatch, path: str,
        headers: tuple[str, ...]) -> None:
    request = connection.request(path, *headers)
    fast = await connection.exchange(request)
    monkeypatch.setattr(Reply, "_head", lambda self, request, length: None)  # aiohttp's way
    slow = await connection.exchange(request)
    assert whole == [True]
    assert fast == slow
    assert fast[0][0].startswith("HTTP/1.1 ")


async def test_a_refused_method_written_whole_is_aiohttps_byte_for_byte(
        connection: Connection, whole: list[bool], monkeypatch: pytest.MonkeyPatch) -> None:
    request = f"DELETE /version HTTP/1.1\r\nHost: {connection.host}\r\n\r\n".encode()
    fast = await connection.exchange(request)
    monkeypatch.setattr(Reply, "_head", lambda self, request, length: None)
    slow = await connection.exchange(request)
    assert whole == [True]
    assert fast == slow
    assert fast[0][0] == "HTTP/1.1 405 Method Not Allowed" and "Allow: GET,HEAD" in fast[0]


@pytest.mark.parametrize(("request_head", "answer"), [
    (b"HEAD /version HTTP/1.1\r\nHost: %s\r\n\r\n", b"HTTP/1.1 200 OK\r\n"),
    (b"GET /version HTTP/1.0\r\nHost: %s\r\n\r\n", b"HTTP/1.0 200 OK\r\n"),
    (b"GET /version HTTP/1.1\r\nHost: %s\r\nConnection: close\r\n\r\n", b"HTTP/1.1 200 OK\r\n"),
])
async def test_what_only_aiohttp_does_is_aiohttps(
        connection: Connection, whole: list[bool], request_head: bytes, answer: bytes) -> None:
    connection.writer.write(request_head % connection.host.encode())
    reply = await connection.reader.read(1 << 16)
    assert reply.startswith(answer)
    assert whole == [False]
    if request_head.startswith(b"HEAD"):
        assert reply.endswith(b"\r\n\r\n") and b"\r\nContent-Length: 5\r\n" in reply  # no body
    else:
        assert reply.endswith(b"\r\n\r\n1.7.3")
    if b"Connection: close" in request_head:
        assert b"\r\nConnection: close\r\n" in reply


async def served_by(app: web.Application, path: str) -> tuple[int, dict[str, str], bytes]:
    """The reply of *app*, served by aiohttp's runner, to a GET of *path*."""
    runner = web.AppRunner(app, access_log=None)
    await runner.setup()
    site = web.TCPSite(runner, "127.0.0.1", 0)
    await site.start()
    try:
        connection = await Connection.open(f"http://127.0.0.1:{runner.addresses[0][1]}")
        try:
            return await connection.get(path)
        finally:
            await connection.close()
    finally:
        await runner.cleanup()


async def test_a_reply_with_a_cookie_goes_aiohttps_way(whole: list[bool]) -> None:
    async def handler(request: web.Request) -> web.StreamResponse:
        reply = json_reply({"signed": True})
        reply.set_cookie("session", "abc", httponly=True)
        return reply

    app = web.Application()
    app.router.add_get("/", handler)
    status, fields, body = await served_by(app, "/")
    assert (status, body, whole) == (200, b'{"signed":true}', [])
    assert fields["Set-Cookie"].startswith("session=abc;")


async def test_an_application_that_changes_replies_as_they_are_prepared_gets_aiohttps_way(whole: list[bool]) -> None:
    async def handler(request: web.Request) -> web.StreamResponse:
        return json_reply({"seen": False})

    async def mark(request: web.Request, response: web.StreamResponse) -> None:
        response.headers["X-Seen"] = "yes"

    app = web.Application()
    app.router.add_get("/", handler)
    app.on_response_prepare.append(mark)
    status, fields, body = await served_by(app, "/")
    assert (status, body, fields["X-Seen"], whole) == (200, b'{"seen":false}', "yes", [False])
