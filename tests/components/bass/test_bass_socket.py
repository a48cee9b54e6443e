"""Issue 9, acceptance 1: the 2015 dedicated socket read by a raw client speaking the MATLAB client's bytes."""

from __future__ import annotations

from collections.abc import AsyncIterator

import aiohttp
import numpy as np
import pytest

from aiogenomix.components.bass import Bass
from aiogenomix.components.core import ComponentHost, HostSettings, ManualClock

from .conftest import MatlabSocket

RATE, FPC = 44100, 2205


@pytest.fixture
async def host() -> AsyncIterator[ComponentHost]:
    """A host whose clock moves only when a test runs the acquisition (:func:`wait_for_frame`).

    The port then holds the frames the test produced, however long a socket read takes on a busy
    machine: what a reply holds and loses is decided by the test, not by the machine's load.
    """
    async with ComponentHost(clock=ManualClock(), settings=HostSettings(audio_socket_port=0),
                             factories={"bass": Bass}) as running:
        yield running


async def wait_for_frame(bass: Bass, frame: int) -> None:
    """Run the acquisition, one chunk of clock time at a time, until bass's newest frame is at least *frame*."""
    assert isinstance(bass.clock, ManualClock)
    while bass.snapshot.last_frame_index < frame:
        await bass.clock.advance(FPC / RATE)


async def start(bass: Bass, chunks: int) -> int:
    await bass.send("DedicatedSocket")
    port = await bass.wait_socket()
    await bass.send("Acquire", {"device": "sim", "sampleRate": RATE, "nFramesPerChunk": FPC, "nChunksOnPort": chunks})
    await wait_for_frame(bass, FPC)
    return port


async def http_frames(http: aiohttp.ClientSession, url: str, first: int) -> tuple[np.ndarray, np.ndarray, int]:
    """The Audio port over HTTP from frame *first* on (``since=first - 1``): left, right and the frames lost."""
    async with http.get(f"{url}/module/bass/read/Audio", params={"since": str(first - 1)}) as reply:
        assert reply.status == 200
        body = await reply.json()
    audio = body["Audio"]
    assert audio["lastFrameIndex"] - len(audio["left"]) + 1 == first
    return np.asarray(audio["left"], np.int32), np.asarray(audio["right"], np.int32), body["lost"]


async def test_reads_200_ms_apart_are_contiguous_and_equal_the_http_port(bass: Bass, url: str) -> None:
    port = await start(bass, chunks=100)          # 5 s on the port: the HTTP check still finds the frames
    await wait_for_frame(bass, 4410)
    client = await MatlabSocket.open(port)
    n, loss, nfr, left, right = await client.read(4410, 0)
    assert (n, loss) == (4410, 0) and nfr == 4410
    assert left[0] == right[0] == 0               # frame 0 is the zero the fresh port starts with
    await wait_for_frame(bass, nfr + int(0.2 * RATE))   # 200 ms later on the runtime clock
    n2, loss2, nfr2, left2, right2 = await client.read(4410, nfr)
    assert (n2, loss2, nfr2) == (4410, 0, nfr + 4410)   # starts where the first reply said, nothing lost
    async with aiohttp.ClientSession() as http:
        for first, got_left, got_right in ((1, left[1:], right[1:]), (nfr, left2, right2)):
            want_left, want_right, lost = await http_frames(http, url, first)
            assert lost == 0
            np.testing.assert_array_equal(got_left, want_left[:len(got_left)])
            np.testing.assert_array_equal(got_right, want_right[:len(got_right)])
    assert np.any(left2 != 0) and not np.array_equal(left2, right2)   # binaural sound, not zeros
    assert await client.close() == b""            # the Close line ends the connection, nothing more is sent


async def test_a_read_from_frame_0_after_5_s_reports_the_frames_lost(bass: Bass) -> None:
    port = await start(bass, chunks=20)           # 1 s on the port
    await wait_for_frame(bass, 5 * RATE)
    client = await MatlabSocket.open(port)
    n, loss, nfr, left, _ = await client.read(4410, 0)
    snapshot_oldest = nfr - n                     # the reply starts at the oldest frame then held
    assert loss == snapshot_oldest and loss >= 5 * RATE - 20 * FPC
    assert n == 4410 and nfr == loss + n
    await client.close()


async def test_asking_more_than_the_port_holds_returns_what_it_holds(bass: Bass) -> None:
    port = await start(bass, chunks=4)
    await wait_for_frame(bass, 10 * FPC)
    client = await MatlabSocket.open(port)
    n, loss, nfr, left, right = await client.read(10**9, 0)
    assert n == 4 * FPC and len(left) == len(right) == n and loss == nfr - n
    assert isinstance(bass.clock, ManualClock)
    await bass.clock.advance(FPC / RATE)  # one more chunk
    n, loss, again, _, _ = await client.read(10**6, nfr)
    assert (n, loss, again) == (FPC, 0, nfr + FPC)  # only what came since
    await bass.clock.advance(5 * FPC / RATE)  # five more: the first of them is no longer held
    n, loss, last, _, _ = await client.read(10**6, again)
    assert (n, loss, last) == (4 * FPC, FPC, again + 5 * FPC)
    await client.close()


async def test_many_clients_and_a_vanished_one_do_not_disturb_the_others(bass: Bass) -> None:
    port = await start(bass, chunks=20)
    clients = [await MatlabSocket.open(port) for _ in range(4)]
    gone = await MatlabSocket.open(port)
    gone.writer.write(b"Read Port - N 44100 - nfr 0\n")
    gone.writer.transport.abort()                 # vanishes without reading its reply
    replies = [await c.read(2205, 0) for c in clients]
    assert all(r[0] == 2205 and r[1] == 0 for r in replies)
    for c in clients:
        await c.close()


async def test_bad_requests_get_an_error_line_and_the_server_goes_on(bass: Bass) -> None:
    port = await start(bass, chunks=20)
    bad = await MatlabSocket.open(port)
    bad.writer.write(b"Read Port - Index 3\n")
    line = await bad.reader.readline()
    assert line.startswith(b"ERROR ") and b"'N <frames>'" in line
    assert await bad.reader.read() == b""
    bad.writer.close()
    good = await MatlabSocket.open(port)
    assert (await good.read(10, 0))[0] == 10
    await good.close()


async def test_with_a_token_the_socket_needs_it_first() -> None:
    async with ComponentHost(clock=ManualClock(), factories={"bass": Bass},
                             settings=HostSettings(audio_socket_port=0, audio_socket_token="s3cret")) as host:
        bass = await host.load("bass")
        assert isinstance(bass, Bass)
        port = await start(bass, chunks=20)
        stranger = await MatlabSocket.open(port)
        stranger.writer.write(b"Read Port - N 10 - nfr 0\n")
        assert (await stranger.reader.readline()).startswith(b"ERROR ")
        assert await stranger.reader.read() == b""
        stranger.writer.close()
        wrong = await MatlabSocket.open(port, token="guess")
        wrong.writer.write(b"Read Port - N 10 - nfr 0\n")
        assert (await wrong.reader.readline()).startswith(b"ERROR ")
        wrong.writer.close()
        friend = await MatlabSocket.open(port, token="s3cret")
        assert (await friend.read(10, 0))[0] == 10
        await friend.close()
