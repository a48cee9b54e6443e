"""The dedicated sockets share one port: a refusal names the component holding it and its CloseSocket.

The README has users open kemarcapture's socket, then bass's: the second is refused while the
first holds the port, and the error says whom to ask, not to restart the gateway.  Only a port
another program holds needs another ``--audio-socket-port``.
"""

from __future__ import annotations

import socket
from collections.abc import AsyncIterator
from typing import Any

import aiohttp
import pytest

from aiogenomix.gateway import GatewayConfig, serve


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@pytest.fixture
async def http_and_port() -> AsyncIterator[tuple[aiohttp.ClientSession, int]]:
    port = _free_port()
    async with serve(GatewayConfig.of(port=0, audio_socket_port=port, time_scale=20)) as url:
        async with aiohttp.ClientSession(base_url=url) as http:
            yield http, port


async def _ended(http: aiohttp.ClientSession, module: str, service: str) -> dict[str, Any]:
    async with http.get(f"/module/{module}/send/{service}") as reply:
        started = await reply.json()
    if started["status"] == "sent":
        async with http.get(f"/module/{module}/wait/{started['id']}?timeout=0.5") as reply:
            started = await reply.json()  # a socket that opened runs on: still sent
    return dict(started)


async def test_the_second_socket_names_the_first_and_its_close(
        http_and_port: tuple[aiohttp.ClientSession, int]) -> None:
    http, port = http_and_port
    for name in ("kemarcapture", "bass"):
        await http.get(f"/load/{name}")
    assert (await _ended(http, "kemarcapture", "DedicatedSocket"))["status"] == "sent"  # serving
    refused = await _ended(http, "bass", "DedicatedSocket")
    assert refused["status"] == "error" and refused["exception"]["ex"] == "::bass::e_socket"
    what = refused["exception"]["detail"]["what"]
    assert f"port {port} is held by kemarcapture's dedicated socket" in what
    assert "call kemarcapture's CloseSocket first" in what and "restart" not in what
    await _ended(http, "kemarcapture", "CloseSocket")
    assert (await _ended(http, "bass", "DedicatedSocket"))["status"] == "sent"  # now it is bass's
    refused = await _ended(http, "kemarcapture", "DedicatedSocket")
    assert "held by bass's dedicated socket: call bass's CloseSocket" in refused["exception"]["detail"]["what"]


async def test_a_port_another_program_holds_names_the_flag(
        http_and_port: tuple[aiohttp.ClientSession, int]) -> None:
    http, port = http_and_port
    await http.get("/load/capture")
    with socket.socket() as other:
        other.bind(("127.0.0.1", port))
        other.listen()
        refused = await _ended(http, "capture", "DedicatedSocket")
    what = refused["exception"]["detail"]["what"]
    assert f"port {port} is used by another program" in what and "--audio-socket-port" in what
