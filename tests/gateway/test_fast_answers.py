"""Plain GETs of ``/`` and ``/version`` are answered ahead of the routes, with the routes' bytes.

The server's request handler answers them from the application alone, with the
route's own function (``gateway/_fast_answers.py``).  These tests ask both ways
(fast, and through the routes: a path with a percent-encoded letter, which only
the routes decode, or a session named, which only the routes take) and compare
the replies byte for byte (but for the ``Date``, and the clock's reading in
``/``); check that every request the door refuses or the routes must decide is
left to them, and that fast answers keep their place among pipelined requests.
Raw sockets, on kept-alive connections as clients use them.
"""

from __future__ import annotations

import json

import pytest

from aiogenomix.gateway import GatewayConfig
from aiogenomix.gateway._fast_answers import FastAnswers
from tests.gateway._raw_http import Connection, answered_ahead

TOKEN = "s3cret-token"


@pytest.fixture
def fast_answers(monkeypatch: pytest.MonkeyPatch) -> list[bool]:
    """Whether each request looked at was answered ahead of the routes (True) or left to them."""
    return answered_ahead(monkeypatch, FastAnswers, "reply")


@pytest.mark.parametrize("query", ["", "?_=1712345678"])
async def test_version_ahead_is_the_routes_reply_byte_for_byte(
        connection: Connection, fast_answers: list[bool], query: str) -> None:
    fast = await connection.exchange(connection.request(f"/version{query}"))
    routed = await connection.exchange(connection.request(f"/versio%6E{query}"))
    assert fast_answers == [True, False]
    assert fast == routed
    assert fast[0][0] == "HTTP/1.1 200 OK" and fast[1] == b"1.7.3"


async def test_the_index_ahead_is_the_routes_reply(connection: Connection, fast_answers: list[bool]) -> None:
    (fast_head, fast_body), (routed_head, routed_body) = [
        await connection.exchange(connection.request(path)) for path in ("/", "/?s=alpha")]
    assert fast_answers == [True, False]
    fast_index, routed_index = json.loads(fast_body), json.loads(routed_body)
    for index in (fast_index, routed_index):
        index["clock"].pop("wall")  # read as each request is answered
    assert fast_index == routed_index
    assert fast_index["loaded"] == {"demo": "demo"}
    assert ([line for line in fast_head if not line.startswith("Content-Length")]
            == [line for line in routed_head if not line.startswith("Content-Length")])


async def test_the_index_ahead_says_what_is_loaded_now(connection: Connection, fast_answers: list[bool]) -> None:
    assert (await connection.get("/load/demo?argv=-i&argv=second"))[0] == 200
    _, _, body = await connection.get("/")
    assert json.loads(body)["loaded"] == {"demo": "demo", "second": "demo"}
    assert fast_answers == [False, True]


@pytest.mark.parametrize(("request_head", "status"), [
    (b"HEAD /version HTTP/1.1\r\nHost: %s\r\n\r\n", 200),
    (b"GET /version HTTP/1.0\r\nHost: %s\r\n\r\n", 200),
    (b"GET /version HTTP/1.1\r\nHost: %s\r\nConnection: close\r\n\r\n", 200),
    (b"GET /version?_=1&_=2 HTTP/1.1\r\nHost: %s\r\n\r\n", 400),
    (b"GET /version?v=1 HTTP/1.1\r\nHost: %s\r\n\r\n", 400),
    (b"GET /version?_=1;v=2 HTTP/1.1\r\nHost: %s\r\n\r\n", 200),  # (one parameter to the routes)
    (b"GET /version HTTP/1.1\r\nHost: %s\r\nOrigin: https://elsewhere.example\r\n\r\n", 403),
    (b"GET /version HTTP/1.1\r\nHost: evil.example\r\n\r\n", 403),
    (b"GET /version HTTP/1.1\r\nHost: %s\r\nSec-Fetch-Site: cross-site\r\n\r\n", 403),
    (b"GET /version HTTP/1.1\r\nHost: %s\r\nOrigin: http://a\r\nOrigin: http://b\r\n\r\n", 400),
    (b"GET /version HTTP/1.1\r\nHost: %s\r\nContent-Length: 2\r\n\r\n{}", 200),
    (b"GET /version HTTP/1.1\r\nHost: %s\r\nExpect: 100-continue\r\n\r\n", 100),  # (then 200)
    (b"GET http://evil.example/version HTTP/1.1\r\nHost: %s\r\n\r\n", 403),
])
async def test_what_the_door_or_the_routes_decide_is_theirs(
        connection: Connection, fast_answers: list[bool], request_head: bytes, status: int) -> None:
    connection.writer.write(request_head.replace(b"%s", connection.host.encode()))
    head = await connection.reader.readuntil(b"\r\n\r\n")
    assert int(head.split(b" ", 2)[1]) == status
    assert not any(fast_answers)  # the door or the routes answered it, never the fast path


@pytest.mark.parametrize("gateway_config", [GatewayConfig.of(port=0, token=TOKEN)])
async def test_a_token_is_asked_of_the_index_by_the_routes(connection: Connection, fast_answers: list[bool]) -> None:
    refused = await connection.get("/")
    assert (refused[0], json.loads(refused[2])["ex"]) == (401, "::genomix::unauthorized")
    answered = await connection.get("/", f"Authorization: Bearer {TOKEN}")
    assert answered[0] == 200 and json.loads(answered[2])["loaded"] == {"demo": "demo"}
    assert fast_answers == [False, True]


async def test_pipelined_requests_are_answered_in_order(connection: Connection, fast_answers: list[bool]) -> None:
    connection.writer.write(connection.request("/version") + connection.request("/module/demo/info")
                            + connection.request("/") + connection.request("/version?_=2"))
    replies = [await connection.reply() for _ in range(4)]
    assert [body[:10] for _, _, body in replies[::2]] == [b"1.7.3", b'{"server":']
    assert json.loads(replies[1][2])["name"] == "demo" and replies[3][2] == b"1.7.3"
    assert fast_answers == [True, False, True, True]
