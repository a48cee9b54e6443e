"""A client cannot fill the log: every refusal of its input is one line at DEBUG, never a traceback.

A request with a header that may appear once given twice (``Host``, ``Content-Type``,
``User-Agent``) was refused with 400 by aiohttp's parser and logged at ERROR with a
full traceback, 407 kB for 500 requests (issue 29).  Two ``Host`` fields, ours then
another, were even answered 200 by the plain reads (issue 32).  Raw sockets: no
client library sends these heads.
"""

from __future__ import annotations

import json
import logging
from collections.abc import AsyncIterator

import pytest
from aiohttp import web

from aiogenomix.gateway import GatewayConfig, create_app, serve
from tests.conftest import TEST_TIME_SCALE
from tests.gateway._raw_http import exchange_once


@pytest.fixture
async def gateway() -> AsyncIterator[str]:
    config = GatewayConfig.of(port=0, time_scale=TEST_TIME_SCALE, audio_socket_port=0, preload=["demo"])
    async with serve(config) as url:
        yield url.removeprefix("http://")


async def _exchange(address: str, raw: bytes) -> tuple[int, bytes]:
    """Send *raw*, read the reply up to the connection's end (a refusal closes it)."""
    status, _, body = await exchange_once(address, raw)
    return status, body


def _head(target: str, address: str, *fields: str) -> bytes:
    return "\r\n".join([f"GET {target} HTTP/1.1", f"Host: {address}", *fields, "", ""]).encode()


DUPLICATED = {
    "Host": ("Host: evil.example",),
    "Content-Type": ("Content-Type: text/plain", "Content-Type: application/json"),
    "User-Agent": ("User-Agent: a", "User-Agent: b"),
}
TARGETS = ["/module/demo/read/Mobile", "/module/demo/send/GetSpeed", "/version"]


def _loud(caplog: pytest.LogCaptureFixture) -> list[logging.LogRecord]:
    """The records a client must not cause: above DEBUG, or carrying a traceback."""
    return [r for r in caplog.records if r.levelno > logging.DEBUG or r.exc_info is not None or r.exc_text]


@pytest.mark.parametrize("target", TARGETS)
@pytest.mark.parametrize("field", list(DUPLICATED))
async def test_a_field_given_twice_is_refused_with_400_and_one_debug_line(
        gateway: str, caplog: pytest.LogCaptureFixture, field: str, target: str) -> None:
    caplog.set_level(logging.DEBUG)
    status, body = await _exchange(gateway, _head(target, gateway, *DUPLICATED[field]))
    assert status == 400
    error = json.loads(body)
    assert error["ex"] == "::genomix::http"
    assert field.lower() in error["message"].lower()
    assert _loud(caplog) == []
    refusals = [r for r in caplog.records if "refused" in r.getMessage()]
    assert len(refusals) == 1


async def test_five_hundred_refused_heads_write_no_traceback(gateway: str, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.DEBUG)
    heads = [_head(target, gateway, *fields) for target in TARGETS for fields in DUPLICATED.values()]
    for index in range(500):
        status, _ = await _exchange(gateway, heads[index % len(heads)])
        assert status == 400
    assert _loud(caplog) == []
    # One short line each at most (rate-limited lines may be fewer).
    assert sum(len(r.getMessage()) for r in caplog.records) < 500 * 200


async def test_the_parsers_refusals_log_no_traceback_under_any_runner(caplog: pytest.LogCaptureFixture) -> None:
    # The application served by aiohttp's own runner: aiohttp's parser refuses the head itself.
    caplog.set_level(logging.DEBUG)
    config = GatewayConfig.of(port=0, time_scale=TEST_TIME_SCALE, audio_socket_port=0, preload=["demo"])
    runner = web.AppRunner(create_app(config), access_log=None)
    await runner.setup()
    await web.TCPSite(runner, "127.0.0.1", 0).start()
    address = f"127.0.0.1:{runner.addresses[0][1]}"
    caplog.clear()  # the start's own lines
    try:
        for fields in DUPLICATED.values():
            status, _ = await _exchange(address, _head("/module/demo/send/GetSpeed", address, *fields))
            assert status == 400
        status, _ = await _exchange(address, b"GET /version HTTP/1.1\r\nHost: x\r\nBad\x01Name: y\r\n\r\n")
        assert status == 400
    finally:
        await runner.cleanup()
    assert _loud(caplog) == []
    refusals = [r.getMessage() for r in caplog.records if "refused" in r.getMessage()]
    assert len(refusals) == 4 and all("\n" not in line for line in refusals)


@pytest.mark.parametrize("target", ["http://evil.example/module/demo/read/Mobile", "http://127.0.0.1:5/x?#frag"])
async def test_a_connect_naming_a_url_is_refused_with_400_and_one_debug_line(
        gateway: str, caplog: pytest.LogCaptureFixture, target: str) -> None:
    # A CONNECT names an authority (host:port); given a URL, aiohttp before 3.14.4 built the request's URL
    # from it, crashed the connection's task (no reply) and logged the traceback at ERROR.
    caplog.set_level(logging.DEBUG)
    status, body = await _exchange(gateway, f"CONNECT {target} HTTP/1.1\r\nHost: {gateway}\r\n\r\n".encode())
    assert status == 400
    assert json.loads(body)["ex"] == "::genomix::http"
    assert _loud(caplog) == []
