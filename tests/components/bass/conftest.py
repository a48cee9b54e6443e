"""Fixtures of the bass/basc tests: a host on a sped-up clock, a gateway in front of it, a MATLAB-like socket client."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator

import numpy as np
import pytest

from aiogenomix.components.basc import Basc
from aiogenomix.components.bass import Bass
from aiogenomix.components.audio import DEFAULT_SCENE, scene_renderer
from aiogenomix.components.core import ComponentHost, HostSettings, ScaledClock
from aiogenomix.components.kemar import Kemar
from aiogenomix.gateway import GatewayConfig, serve

#: One second of audio takes 100 ms of real time in these tests.
TIME_SCALE = 10.0
#: Real seconds the simulated drive, served by a thread, has to answer: the CAN reply timeout is real time
#: by design (decision 8), and a loaded machine may starve the thread past the default 0.5 s.
CAN_TIMEOUT = 10.0


@pytest.fixture
async def host() -> AsyncIterator[ComponentHost]:
    """A host with bass, basc and kemar loadable; the dedicated socket takes a free port."""
    settings = HostSettings(audio_socket_port=0, can_timeout=CAN_TIMEOUT)
    async with ComponentHost(clock=ScaledClock(TIME_SCALE), settings=settings,
                             factories={"bass": Bass, "basc": Basc, "kemar": Kemar}) as running:
        yield running


@pytest.fixture
async def bass(host: ComponentHost) -> Bass:
    component = await host.load("bass")
    assert isinstance(component, Bass)
    return component


@pytest.fixture
async def url(host: ComponentHost) -> AsyncIterator[str]:
    """A gateway serving the same host on a free loopback port."""
    async with serve(GatewayConfig(port=0), host=host) as base:
        yield base


def reference_frames(count: int, azimuths: list[float] | None = None, rate: int = 44100,
                     frames_per_chunk: int = 2205) -> np.ndarray:
    """The first *count* frames the default simulated scene renders, chunk by chunk, at the given head azimuths."""
    renderer = scene_renderer(DEFAULT_SCENE, rate)
    chunks = -(-count // frames_per_chunk)
    angles = azimuths if azimuths is not None else [0.0] * chunks
    return np.concatenate([renderer.render(frames_per_chunk, az) for az in angles[:chunks]])[:count]


async def wait_for_frame(bass: Bass, frame: int) -> None:
    """Wait (on publications, never on time) until bass's newest frame is at least *frame*."""
    while bass.snapshot.last_frame_index < frame:
        await bass.Audio.wait_published()


class MatlabSocket:
    """Speaks byte for byte what the public Two!Ears MATLAB client speaks (``dedicatedSocket*.m``).

    ``fprintf`` on a MATLAB ``tcpip`` object ends each line with LF; the reply is
    read as a 16-byte header, then ``n * 2 * 4`` bytes, left block then right block.
    """

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.reader, self.writer = reader, writer

    @classmethod
    async def open(cls, port: int, token: str | None = None) -> MatlabSocket:
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        if token is not None:
            writer.write(f"Token {token}\n".encode())
        return cls(reader, writer)

    async def read(self, frames: int, next_frame: int) -> tuple[int, int, int, np.ndarray, np.ndarray]:
        """``[n, loss, nfr, data] = dedicatedSocketRead(N, nfr)``: returns n, loss, the next nfr, left, right."""
        self.writer.write(f"Read Port - N {frames} - nfr {next_frame}\n".encode("ascii"))
        header = await asyncio.wait_for(self.reader.readexactly(16), 10)
        n = header[0] + header[1] * 256 + header[2] * 65536 + header[3] * 16777216
        loss = int.from_bytes(header[4:8], "little")
        nfr = sum(header[8 + i] * 256**i for i in range(8))
        body = await asyncio.wait_for(self.reader.readexactly(n * 2 * 4), 10)
        samples = np.frombuffer(body, dtype="<i4")
        return n, loss, nfr, samples[:n], samples[n:]

    async def close(self) -> bytes:
        """``dedicatedSocketClose``: the ``Close`` line; returns what the server sent before closing."""
        self.writer.write(b"Close\n")
        rest = await asyncio.wait_for(self.reader.read(), 10)
        self.writer.close()
        return rest
