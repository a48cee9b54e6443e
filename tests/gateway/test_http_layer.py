"""What aiohttp's parser refuses reaches the client as the documented JSON, without a log flood.

Raw sockets throughout: these requests are the ones no HTTP client library would send.
"""

from __future__ import annotations

import asyncio
import dataclasses
import json
import logging
from collections.abc import AsyncIterator

import pytest

from aiogenomix.gateway import GatewayConfig, serve
from aiogenomix.gateway.__main__ import parse_args
from tests.conftest import TEST_TIME_SCALE
from tests.gateway._raw_http import exchange_once, open_raw


@pytest.fixture
def gateway_config() -> GatewayConfig:
    # A short head timeout, so that the timeout test waits half a second, not ten.
    return GatewayConfig.of(port=0, time_scale=TEST_TIME_SCALE, audio_socket_port=0, header_timeout=0.5)


@pytest.fixture
async def gateway(gateway_config: GatewayConfig) -> AsyncIterator[str]:
    async with serve(gateway_config) as url:
        yield url


def _named(url: str, raw: bytes) -> bytes:
    """*raw* with its ``Host: x`` naming the gateway as a browser would."""
    return raw.replace(b"Host: x\r\n", f"Host: {url.removeprefix('http://')}\r\n".encode())


async def _exchange(url: str, raw: bytes) -> tuple[int, dict[str, str], bytes]:
    """Send *raw* (``Host: x`` named properly), read the reply up to the connection's end."""
    status, head, body = await exchange_once(url, _named(url, raw))
    _, *lines = head.decode("latin-1").split("\r\n")
    headers = {name.lower(): value for name, _, value in (line.partition(": ") for line in lines)}
    return status, headers, body


def _assert_documented_error(status: int, headers: dict[str, str], body: bytes, expected: int) -> str:
    assert status == expected
    assert headers["content-type"] == "application/json"
    assert int(headers["content-length"]) == len(body)
    error = json.loads(body)
    assert error["ex"] == "::genomix::http"
    assert error["message"]
    return str(error["message"])


REFUSED = [
    ("not HTTP at all", b"GARBAGE\r\n\r\n", 400),
    ("a header line without a colon", b"GET /version HTTP/1.1\r\nHost: x\r\nno colon here\r\n\r\n", 400),
    ("a header line of 9000 bytes", b"GET /version HTTP/1.1\r\nHost: x\r\nX-Big: " + b"a" * 9000 + b"\r\n\r\n", 431),
    ("an HTTP/0.9 request line", b"GET /version\r\n\r\n", 505),
    ("HTTP/2.0 in a request line", b"GET /version HTTP/2.0\r\nHost: x\r\n\r\n", 505),
]


@pytest.mark.parametrize(("what", "raw", "expected"), REFUSED, ids=[r[0] for r in REFUSED])
async def test_parser_refusals_are_documented_json_without_a_traceback(
        gateway: str, caplog: pytest.LogCaptureFixture, what: str, raw: bytes, expected: int) -> None:
    caplog.set_level(logging.DEBUG)
    status, headers, body = await _exchange(gateway, raw)
    _assert_documented_error(status, headers, body, expected)
    assert b"1.7.3" not in body  # HTTP/0.9 got the version before
    noisy = [r for r in caplog.records if r.levelno >= logging.INFO and r.name.startswith("aiohttp")]
    assert noisy == []
    refusals = [r for r in caplog.records if "refused" in r.getMessage()]
    assert len(refusals) == 1 and refusals[0].levelno == logging.DEBUG and refusals[0].exc_info is None


async def test_a_20_mb_input_gets_414_rather_than_a_reset(gateway_config: GatewayConfig) -> None:
    # The refusal, not the timeout, however long a busy machine takes.
    limits = dataclasses.replace(gateway_config.connections, header_timeout=10)
    async with serve(dataclasses.replace(gateway_config, connections=limits)) as gateway:
        await _send_20_mb(gateway)


async def _send_20_mb(gateway: str) -> None:
    reader, writer = await open_raw(gateway)
    try:
        # Sent whole before reading, as most HTTP clients do: the gateway must let the client finish.
        writer.write(_named(gateway, b"GET /module/demo/send/GotoPosition?input=" + b"1" * 20_000_000
                            + b" HTTP/1.1\r\nHost: x\r\n\r\n"))
        await writer.drain()
        reply = await asyncio.wait_for(reader.read(), 10)
    finally:
        writer.close()
    head, _, body = reply.partition(b"\r\n\r\n")
    assert head.split(b"\r\n")[0].split()[1] == b"414"
    error = json.loads(body)
    assert error["ex"] == "::genomix::http"
    assert "65536 bytes" in error["message"]


async def test_the_url_limit_is_a_flag_and_input_below_it_is_read(gateway_config: GatewayConfig) -> None:
    limits = dataclasses.replace(gateway_config.connections, max_url_bytes=200_000)
    async with serve(dataclasses.replace(gateway_config, connections=limits)) as url:
        # 100 kB of JSON: past aiohttp's 8190 bytes, within the limit given.
        members = ",".join(['"x":1'] * 20_000)
        query = f"/module/demo/send/GotoPosition?input={{{members}}}".encode()
        status, _, body = await _exchange(url, b"GET /load/demo HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
        assert status == 200
        status, _, body = await _exchange(url, b"GET " + query + b" HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
        assert status == 400 and json.loads(body)["ex"] == "::genom::serialization"  # read, then refused: no x


async def test_a_head_sent_too_slowly_gets_408_and_the_connection_ends(gateway: str) -> None:
    slow_reader, slow_writer = await open_raw(gateway)
    silent_reader, silent_writer = await open_raw(gateway)
    try:
        slow_writer.write(_named(gateway, b"GET /version HTTP/1.1\r\nHost: x\r\n"))  # and never the blank line
        await slow_writer.drain()
        # Meanwhile a prompt client is served on a connection of its own.
        status, _, body = await _exchange(gateway, b"GET /version HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
        assert (status, body) == (200, b"1.7.3")
        for reader in (slow_reader, silent_reader):
            reply = await asyncio.wait_for(reader.read(), 10)  # ends: the gateway closed it
            head, _, body = reply.partition(b"\r\n\r\n")
            assert head.split(b"\r\n")[0].split()[1] == b"408"
            assert json.loads(body)["ex"] == "::genomix::http"
    finally:
        slow_writer.close()
        silent_writer.close()


async def test_a_keep_alive_connection_serves_several_requests(gateway: str) -> None:
    reader, writer = await open_raw(gateway)
    try:
        for _ in range(3):
            writer.write(_named(gateway, b"GET /version HTTP/1.1\r\nHost: x\r\n\r\n"))
            await writer.drain()
            head = await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), 10)
            assert head.startswith(b"HTTP/1.1 200")
            assert await reader.readexactly(5) == b"1.7.3"
    finally:
        writer.close()


def test_the_limits_are_flags(capsys: pytest.CaptureFixture[str]) -> None:
    config = parse_args(["--header-timeout", "2.5", "--max-url-bytes", "100000", "--session-idle", "30",
                         "--max-sessions", "10", "--max-instances", "3"])
    connections, sessions = config.connections, config.sessions
    assert (connections.header_timeout, connections.max_url_bytes, sessions.session_idle) == (2.5, 100_000, 30.0)
    assert (sessions.max_sessions, sessions.max_instances) == (10, 3)
    defaults = parse_args([])
    connections, sessions = defaults.connections, defaults.sessions
    assert (connections.header_timeout, connections.max_url_bytes, sessions.session_idle) == (10.0, 65536, 600.0)
    assert (sessions.max_sessions, sessions.max_instances) == (256, 64)
    for bad in (["--max-url-bytes", "8190"], ["--header-timeout", "nan"], ["--max-sessions", "0"]):
        with pytest.raises(SystemExit):
            parse_args(bad)
    assert "--max-url-bytes" in capsys.readouterr().err


@pytest.mark.parametrize("expect", [True, False], ids=["Expect: 100-continue", "no Expect"])
async def test_a_body_announced_too_large_gets_413_at_once(gateway: str, expect: bool) -> None:
    # 64 MiB announced, none of it sent: the client waits for an answer before sending (curl waits 1 s).
    reader, writer = await open_raw(gateway)
    try:
        writer.write(_named(gateway, b"POST /module/demo/send/GotoPosition HTTP/1.1\r\nHost: x\r\n"
                            b"Content-Type: application/json\r\nContent-Length: 67108864\r\n"
                            + (b"Expect: 100-continue\r\n" if expect else b"") + b"\r\n"))
        await writer.drain()
        head = await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), 5)
        assert head.startswith(b"HTTP/1.1 413 ")  # at once, and no 100 Continue before it
        assert b"\r\nConnection: close\r\n" in head
        body = await reader.readexactly(int(head.split(b"Content-Length: ")[1].split(b"\r\n")[0]))
        # A client may send its body all the same (RFC 9110, 10.1.1): it is dropped, and the connection ends.
        writer.write(bytes(64 << 20))
        assert await asyncio.wait_for(reader.read(), 10) == b""
    finally:
        writer.close()
    error = json.loads(body)
    assert error["ex"] == "::genomix::http" and "1048576 bytes" in error["message"]
