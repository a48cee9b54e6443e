"""Plain port reads are answered as soon as they are parsed, with the bytes the routes would answer.

The connection answers a ``GET /module/M/read/P`` that needs nothing more
(``gateway/_fast_reads.py``).  These tests read the same publication both ways
(fast, and through the routes: a path with a percent-encoded letter, which
only the routes decode) and compare the replies byte for byte; check that every
request the routes refuse or answer with an error still gets the routes'
answer; and that fast answers keep their place among pipelined requests.
Raw sockets throughout, on kept-alive connections as polling clients use them.
"""

from __future__ import annotations

import asyncio
import json
import socket
import struct
from collections.abc import AsyncIterator

import pytest

from aiogenomix.components.capture import PortView
from aiogenomix.components.core import ComponentHost, ScaledClock
from aiogenomix.components.kemarcapture import KemarPortData
from aiogenomix.gateway import GatewayConfig, serve
from aiogenomix.gateway._fast_reads import FastReads
from aiogenomix.gateway._routes_ports import READ_HEADERS
from tests.gateway._raw_http import Connection, address, answered_ahead
from tests.gateway.test_port_pieces import Windowed, expected_binary, expected_json, window

TOKEN = "s3cret"


@pytest.fixture
def fast_answers(monkeypatch: pytest.MonkeyPatch) -> list[bool]:
    """Whether each request the connection looked at was answered there (True) or left to the routes."""
    return answered_ahead(monkeypatch, FastReads, "reply")


@pytest.fixture
async def served(gateway_config: GatewayConfig) -> AsyncIterator[tuple[Windowed, Connection]]:
    async with ComponentHost(clock=ScaledClock(1), factories={"windowed": Windowed}) as host:
        component = await host.load("windowed")
        assert isinstance(component, Windowed)
        async with serve(gateway_config, host=host) as url:
            connection = await Connection.open(url)
            try:
                yield component, connection
            finally:
                await connection.close()


def published(component: Windowed, seed: int = 1) -> PortView:
    view = PortView(window(12, 2205, 10, seed=seed), 44100, 0.0, KemarPortData)
    component.Port.publish(view)
    return view


@pytest.mark.parametrize("query", ["", "?format=json", "?format=binary", "?since=4", "?format=binary&since=4",
                                   "?since=0", "?since=99", "?format="])
async def test_a_fast_read_is_the_routes_reply_byte_for_byte(
        served: tuple[Windowed, Connection], fast_answers: list[bool], query: str) -> None:
    component, connection = served
    view = published(component)
    fast = await connection.get(f"/module/windowed/read/Port{query}")
    routed = await connection.get(f"/module/windowed/read/%50ort{query}")  # %50 is P
    assert fast_answers == [True, False]
    (status, fields, body), (routed_status, routed_fields, routed_body) = fast, routed
    assert status == routed_status == 200
    assert body == routed_body
    fields.pop("Date"), routed_fields.pop("Date")
    assert fields == routed_fields
    assert list(fields) == [*READ_HEADERS["binary" in query], "Content-Length"]  # aiohttp's order too
    since = int(query.rsplit("=", 1)[1]) if "since" in query else None
    assert body == (expected_binary(view, since) if "binary" in query else expected_json(view, since))


async def test_the_accept_header_asks_for_the_binary_form(
        served: tuple[Windowed, Connection], fast_answers: list[bool]) -> None:
    component, connection = served
    view = published(component)
    status, fields, body = await connection.get("/module/windowed/read/Port",
                                                "Accept: application/x-aiogenomix-binary")
    assert (status, fields["Content-Type"], body) == (200, "application/x-aiogenomix-binary", expected_binary(view))
    assert fast_answers == [True]


@pytest.mark.parametrize(("path", "headers", "status", "ex"), [
    ("/module/nobody/read/Port", (), 404, "::genomix::no_such_module"),
    ("/module/windowed/read/Nothing", (), 404, "::genom::no_such_outport"),
    ("/module/windowed/read/Port?since=-1", (), 400, "::genom::serialization"),
    ("/module/windowed/read/Port?since=x", (), 400, "::genom::serialization"),
    ("/module/windowed/read/Port?format=xml", (), 400, "::genom::serialization"),
    ("/module/windowed/read/Port?name=left", (), 400, "::genom::serialization"),
    ("/module/windowed/read/Port", ("Sec-Fetch-Site: cross-site",), 403, "::genomix::forbidden"),
    ("/module/windowed/read/Port", ("Host: rebound.example",), 403, "::genomix::forbidden"),
    ("/module/windowed/read/Port", ("Origin: https://elsewhere.example",), 403, "::genomix::forbidden"),
])
async def test_refusals_and_errors_are_the_routes(
        served: tuple[Windowed, Connection], fast_answers: list[bool], path: str, headers: tuple[str, ...],
        status: int, ex: str) -> None:
    component, connection = served
    published(component)
    request = connection.request(path, *headers)
    if any(header.startswith("Host:") for header in headers):  # the request names another host
        request = request.replace(f"Host: {connection.host}\r\n".encode(), b"", 1)
    connection.writer.write(request)
    answer_status, _, body = await connection.reply()
    assert (answer_status, json.loads(body)["ex"]) == (status, ex)
    assert not any(fast_answers)
    # The connection goes on, and its next plain read is answered fast.
    assert (await connection.get("/module/windowed/read/Port"))[0] == 200
    assert fast_answers[-1] is True


@pytest.mark.parametrize(("header", "version"), [("Connection: close", "1.1"), ("User-Agent: old", "1.0")])
async def test_reads_that_close_the_connection_are_the_routes(
        served: tuple[Windowed, Connection], fast_answers: list[bool], header: str, version: str) -> None:
    component, connection = served
    view = published(component)
    assert (await connection.get("/module/windowed/read/Port", header, version=version))[2] == expected_json(view)
    assert await connection.reader.read() == b""  # closed after the reply, as asked
    assert fast_answers == [False]


class TestWithAToken:
    @pytest.fixture
    def gateway_config(self) -> GatewayConfig:
        return GatewayConfig.of(port=0, token=TOKEN)

    async def test_only_a_read_with_the_token_is_answered(
            self, served: tuple[Windowed, Connection], fast_answers: list[bool]) -> None:
        component, connection = served
        view = published(component)
        status, _, body = await connection.get("/module/windowed/read/Port")
        assert (status, json.loads(body)["ex"]) == (401, "::genomix::unauthorized")
        status, _, body = await connection.get("/module/windowed/read/Port", "Authorization: Bearer wrong")
        assert status == 401
        status, _, body = await connection.get("/module/windowed/read/Port", f"Authorization: Bearer {TOKEN}")
        assert (status, body) == (200, expected_json(view))
        assert fast_answers == [False, False, True]


async def test_pipelined_requests_are_answered_in_order(
        served: tuple[Windowed, Connection], fast_answers: list[bool]) -> None:
    component, connection = served
    view = published(component)
    read = connection.request("/module/windowed/read/Port?format=binary")
    connection.writer.write(read + connection.request("/module/windowed/info") + read)
    first, info, last = [await connection.reply() for _ in range(3)]
    assert first[2] == last[2] == expected_binary(view)
    assert json.loads(info[2])["name"] == "windowed"
    # aiohttp hands the requests over one by one: the first read went at once, the info to the routes,
    # and the last read was looked at only once the info was answered.
    assert fast_answers[:2] == [True, False] and len(fast_answers) == 3


async def test_a_reader_that_vanishes_mid_reply_leaves_the_gateway_serving(
        served: tuple[Windowed, Connection], fast_answers: list[bool]) -> None:
    component, connection = served
    view = PortView(window(80, 20_000, 80, seed=2), 44100, 0.0, KemarPortData)
    component.Port.publish(view)
    host, port = address(connection.host)
    for _ in range(3):
        sock = socket.socket()
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        sock.setblocking(False)
        loop = asyncio.get_running_loop()
        await loop.sock_connect(sock, (host, port))
        await loop.sock_sendall(sock, connection.request("/module/windowed/read/Port"))
        assert (await loop.sock_recv(sock, 1024)).startswith(b"HTTP/1.1 200 OK")
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))  # a reset, not a close
        sock.close()
    status, _, body = await connection.get("/module/windowed/read/Port?format=binary")
    assert (status, body) == (200, expected_binary(view))
    assert fast_answers == [True] * 4
