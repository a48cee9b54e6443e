"""Every request head is judged once, by the door, whichever way the gateway answers it (issue 32).

Two ``Host`` fields (ours, then another) were answered 200 by the plain reads
while the routes refused the same head; a target in absolute form
(``GET http://evil.example/...``) was answered as if its authority were the
gateway's, though HTTP/1.1 makes that authority the request's host.  Raw sockets.
"""

from __future__ import annotations

import json
from collections.abc import AsyncIterator

import pytest

from aiogenomix.gateway import GatewayConfig, serve
from tests.conftest import TEST_TIME_SCALE
from tests.gateway._raw_http import exchange_once

READ = "/module/demo/read/Mobile"
SEND = "/module/demo/send/GetSpeed"


@pytest.fixture
async def gateway() -> AsyncIterator[str]:
    config = GatewayConfig.of(port=0, time_scale=TEST_TIME_SCALE, audio_socket_port=0, preload=["demo"])
    async with serve(config) as url:
        yield url.removeprefix("http://")


async def _status(address: str, target: str, *fields: str, host: str | None = None) -> tuple[int, dict[str, str]]:
    """The status and JSON body of ``GET target`` with *fields* (``Host: address`` first unless *host*)."""
    lines = [f"GET {target} HTTP/1.1", f"Host: {host or address}", *fields, "Connection: close", "", ""]
    status, _, body = await exchange_once(address, "\r\n".join(lines).encode())
    return status, json.loads(body)


@pytest.mark.parametrize("target", [READ, SEND])
async def test_an_absolute_form_names_the_host_it_is_judged_by(gateway: str, target: str) -> None:
    status, body = await _status(gateway, f"http://evil.example{target}")
    assert (status, body["ex"]) == (403, "::genomix::forbidden")
    assert "evil.example" in body["message"]
    # Our own authority in the target is served, whatever Host says (RFC 9112, 3.2.2).
    status, _ = await _status(gateway, f"http://{gateway}{target}", host="evil.example")
    assert status == 200


@pytest.mark.parametrize("target", [READ, SEND])
async def test_two_origins_are_refused(gateway: str, target: str) -> None:
    status, body = await _status(gateway, target, f"Origin: http://{gateway}", "Origin: https://evil.example")
    assert (status, body["ex"]) == (400, "::genomix::http")
    assert "Origin" in body["message"]
