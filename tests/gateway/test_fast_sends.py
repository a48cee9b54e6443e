"""Plain sends are answered ahead of the routes, with the bytes and the effects the ``send`` route has.

The server's request handler answers a ``GET /module/M/send/S`` that needs
nothing of the routes (``gateway/_fast_sends.py``).  These tests send the same
service both ways (fast, and through the routes: a path with a percent-encoded
letter, which only the routes decode) and compare the replies byte for byte (the
request's number apart); check that what the route answers with an error gets
the same error, that every request the door refuses or the routes must decide
is left to them, and that fast answers keep their place among pipelined
requests.  Raw sockets, on kept-alive connections as clients use them.
"""

from __future__ import annotations

import json

import pytest

from aiogenomix.gateway._fast_sends import FastSends
from aiogenomix.gateway._replies import JSON_HEADERS
from tests.gateway._raw_http import Connection, answered_ahead


@pytest.fixture
def fast_answers(monkeypatch: pytest.MonkeyPatch) -> list[bool]:
    """Whether each request looked at was taken as a plain send (True) or left to the routes."""
    return answered_ahead(monkeypatch, FastSends, "plain")


def numberless(body: bytes) -> dict[str, object]:
    """The reply's status object without its request's number (each send makes a request)."""
    found = json.loads(body)
    found["id"] = found["id"].rsplit("::", 1)[0]
    return found


@pytest.mark.parametrize("query", ["", "?s=alpha", "?oneway", "?oneway=1&s=beta&_=17",
                                   '?input={"speedRef":"::demo::SLOW"}', "?input={}", "?s="])
async def test_a_fast_send_is_the_routes_reply_byte_for_byte(
        connection: Connection, fast_answers: list[bool], query: str) -> None:
    service = "SetSpeed" if "input" in query else "GetSpeed"
    fast = await connection.get(f"/module/demo/send/{service}{query}")
    routed = await connection.get(f"/module/demo/send/%{ord(service[0]):X}{service[1:]}{query}")
    assert fast_answers == [True, False]
    (status, fields, body), (routed_status, routed_fields, routed_body) = fast, routed
    assert status == routed_status == 200
    assert numberless(body) == numberless(routed_body)
    assert numberless(body)["status"] == "done"
    assert len(body) == len(routed_body)
    fields.pop("Date"), routed_fields.pop("Date")
    assert fields == routed_fields
    assert list(fields) == [*JSON_HEADERS, "Content-Length"]  # aiohttp's order too


async def test_a_fast_send_runs_the_service(connection: Connection, fast_answers: list[bool]) -> None:
    status, _, body = await connection.get('/module/demo/send/SetSpeed?input={"speedRef":"::demo::FAST"}')
    assert status == 200 and json.loads(body)["status"] == "done"
    status, _, body = await connection.get("/module/demo/send/GetSpeed")
    assert json.loads(body)["output"] == {"speedRef": "::demo::FAST"}
    assert fast_answers == [True, True]


@pytest.mark.parametrize(("path", "status", "ex"), [
    ("/module/nobody/send/GetSpeed", 404, "::genomix::no_such_module"),
    ("/module/demo/send/Nothing", 404, "::genom::no_such_service"),
    ("/module/demo/send/SetSpeed?input=[", 400, "::genom::serialization"),
    ("/module/demo/send/SetSpeed?input=7", 400, "::genom::serialization"),
    ("/module/demo/send/GetSpeed?s=" + "x" * 129, 400, "::genom::serialization"),
])
async def test_errors_are_the_routes(
        connection: Connection, fast_answers: list[bool], path: str, status: int, ex: str) -> None:
    fast = await connection.get(path)
    service = path.split("/")[4]
    routed = await connection.get(path.replace(f"/{service}", f"/%{ord(service[0]):X}{service[1:]}", 1))
    assert fast_answers == [True, False]
    assert (fast[0], json.loads(fast[2])["ex"]) == (routed[0], json.loads(routed[2])["ex"]) == (status, ex)
    assert fast[2] == routed[2]


@pytest.mark.parametrize(("path", "headers", "status", "ex"), [
    ("/module/demo/send/GetSpeed?speed=1", (), 400, "::genomix::bad_parameter"),
    ("/module/demo/send/GetSpeed?s=a&s=b", (), 400, "::genomix::bad_parameter"),
    ("/module/demo/send/GetSpeed?s=a;b=c", (), 200, None),
    ("/module/demo/send/..", (), 404, "::genom::no_such_service"),
    ("/module//send/GetSpeed", (), 404, "::genomix::http"),
    ("/module/demo/send/GetSpeed", ("Sec-Fetch-Site: cross-site",), 403, "::genomix::forbidden"),
    ("/module/demo/send/GetSpeed", ("Origin: https://elsewhere.example",), 403, "::genomix::forbidden"),
    ("/module/demo/send/GetSpeed", ("Content-Length: 2",), 200, None),
])
async def test_what_the_door_or_the_routes_decide_is_theirs(
        connection: Connection, fast_answers: list[bool], path: str, headers: tuple[str, ...], status: int,
        ex: str | None) -> None:
    connection.writer.write(connection.request(path, *headers) + (b"{}" if "Content-Length: 2" in headers else b""))
    answer_status, _, body = await connection.reply()
    assert answer_status == status
    assert ex is None or json.loads(body)["ex"] == ex
    assert not any(fast_answers)
    # The connection goes on, and its next plain send is answered fast.
    assert (await connection.get("/module/demo/send/GetSpeed"))[0] == 200
    assert fast_answers[-1] is True


async def test_pipelined_requests_are_answered_in_order(connection: Connection, fast_answers: list[bool]) -> None:
    sends = [connection.request(f"/module/demo/send/GetSpeed?_={n}") for n in range(3)]
    connection.writer.write(sends[0] + connection.request("/module/demo/info") + sends[1] + sends[2])
    replies = [await connection.reply() for _ in range(4)]
    assert [json.loads(body).get("id") for _, _, body in replies] == ["demo::0", None, "demo::1", "demo::2"]
    assert json.loads(replies[1][2])["name"] == "demo"
    assert fast_answers == [True, False, True, True]
