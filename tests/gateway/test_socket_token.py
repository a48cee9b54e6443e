"""Issue 14, defect 7: with --token, both generations of the dedicated audio socket require the token."""

from __future__ import annotations

import asyncio
import socket

import aiohttp
import orjson
import pytest

from aiogenomix.clients import AsyncAudioSocketClient, AsyncFrameSocketClient, AudioSocketError
from aiogenomix.gateway import GatewayConfig

from ..conftest import TEST_TIME_SCALE

TOKEN = "s3cret"
AUTH = {"Authorization": f"Bearer {TOKEN}"}


@pytest.fixture
def gateway_config() -> GatewayConfig:
    with socket.socket() as probe:          # a free port, known to the test, for the dedicated socket
        probe.bind(("127.0.0.1", 0))
        free = probe.getsockname()[1]
    return GatewayConfig.of(port=0, time_scale=TEST_TIME_SCALE, audio_socket_port=free, token=TOKEN)


async def send(http: aiohttp.ClientSession, path: str) -> None:
    async with http.get(path, headers=AUTH) as reply:
        assert reply.status == 200, await reply.text()


async def open_socket(http: aiohttp.ClientSession, module: str) -> None:
    """Load *module*, open its dedicated socket (it listens once the request runs), capture, await a first chunk."""
    await send(http, f"/load/{module}")
    await send(http, f"/module/{module}/send/DedicatedSocket")
    await send(http, f"/module/{module}/send/{'Acquire' if module == 'bass' else 'StartCapture'}")
    # A read before the first chunk finds no frame to send (on a busy machine it comes late).
    port = "Audio" if module == "bass" else "Port"
    async with http.get(f"/module/{module}/watch/{port}", headers=AUTH) as stream:
        async for line in stream.content:
            if line.startswith(b"data: ") and orjson.loads(line[6:])[port][
                    "lastFrameIndex" if module == "bass" else "index"] > 0:
                break


async def raw_exchange(port: int, lines: bytes) -> bytes:
    """What the socket answers to *lines*, up to its closing the connection."""
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    writer.write(lines)
    data = await asyncio.wait_for(reader.read(), 10)
    writer.close()
    return data


@pytest.mark.parametrize(("module", "request_line"), [("capture", b"Read Port - Index 0\n"),
                                                      ("bass", b"Read Port - N 10 - nfr 0\n")])
async def test_a_client_without_the_token_reads_no_audio(http: aiohttp.ClientSession, gateway_config: GatewayConfig,
                                                         module: str, request_line: bytes) -> None:
    await open_socket(http, module)
    port = gateway_config.rig.audio_socket_port
    for lines in (request_line, b"Token guess\n" + request_line, b"Bearer " + TOKEN.encode() + b"\n" + request_line):
        answer = await raw_exchange(port, lines)
        assert answer.startswith(b"ERROR ") and answer.endswith(b"\n") and answer.count(b"\n") == 1
    answer = await raw_exchange(port, f"Token {TOKEN}\n".encode() + request_line + b"Close\n")
    assert not answer.startswith(b"ERROR") and len(answer) > 16


async def test_the_python_clients_send_the_token(http: aiohttp.ClientSession, gateway_config: GatewayConfig) -> None:
    await open_socket(http, "bass")
    port = gateway_config.rig.audio_socket_port
    with pytest.raises(AudioSocketError, match="refused"):
        async with AsyncFrameSocketClient(port=port) as stranger:
            await stranger.read(10)
    async with AsyncFrameSocketClient(port=port, token=TOKEN) as friend:
        assert (await friend.read(1)).count == 1
    await send(http, "/module/bass/send/CloseSocket")
    await send(http, "/unload/bass")
    await open_socket(http, "capture")
    with pytest.raises(AudioSocketError, match="refused"):
        async with AsyncAudioSocketClient(port=port) as stranger_2014:
            await stranger_2014.read()
    async with AsyncAudioSocketClient(port=port, token=TOKEN) as friend_2014:
        assert (await friend_2014.read()).last_index >= 0
