"""Port reads of the generated client: binary when offered, fast JSON otherwise, incremental with since=."""

from __future__ import annotations

from collections.abc import AsyncIterator

import numpy as np
import orjson
import pytest

from aiogenomix.clients import aconnect
from aiogenomix.clients._fastjson import loads_with_arrays
from aiogenomix.components.capture import Capture
from aiogenomix.components.core import ComponentHost, HostSettings, ManualClock
from aiogenomix.gateway import GatewayConfig, serve


async def capture_until(capture: Capture, index: int) -> None:
    """Run the capture's clock, one chunk (50 ms) at a time, until chunk *index* is on the port."""
    assert isinstance(capture.clock, ManualClock)
    while capture.Port.read().index < index:
        await capture.clock.advance(0.05)


@pytest.fixture
async def capturing() -> AsyncIterator[tuple[Capture, str]]:
    """A simulated capture with 8 chunks on the port (full), served on a free port.

    Its clock moves only when a test says: the window the reads see stays as it is, however
    slowly the machine answers.
    """
    async with ComponentHost(clock=ManualClock(), settings=HostSettings(audio_socket_port=0),
                             factories={"capture": Capture}) as host:
        capture = await host.load("capture")
        assert isinstance(capture, Capture)
        await capture.send("StartCapture", {"device": "sim", "Port_chunks": 8})
        await capture_until(capture, 8)
        async with serve(GatewayConfig.of(port=0), host=host) as url:
            yield capture, url


@pytest.mark.parametrize("fast_paths", [True, False], ids=["binary", "json"])
async def test_port_reads_give_numpy_arrays_equal_to_the_json(capturing: tuple[Capture, str],
                                                            fast_paths: bool) -> None:
    capture, url = capturing
    async with aconnect(url, fast_paths=fast_paths) as client:
        assert ("binary" in client.features) is fast_paths
        port = (await client.module("capture")).Port
        data = await port()
        raw = (await port(raw=True))["Port"]
    assert isinstance(data.left, np.ndarray) and data.left.dtype == np.int32
    assert data.left.size == data.nbframes == 8 * 2205
    assert raw["index"] == data.index == 8  # the clock stood still between the two reads
    np.testing.assert_array_equal(data.left, np.asarray(raw["left"], np.int32))


@pytest.mark.parametrize("fast_paths", [True, False], ids=["binary", "json"])
async def test_since_returns_only_new_chunks_and_losses(capturing: tuple[Capture, str], fast_paths: bool) -> None:
    capture, url = capturing
    async with aconnect(url, fast_paths=fast_paths) as client:
        port = (await client.module("capture")).Port
        await capture_until(capture, 30)
        whole = await port()
        newest, lost = await port(since=whole.index - 3)  # the 3 chunks after whole.index - 3, no more
        assert lost == 0 and newest.index == whole.index
        assert newest.left.size == 3 * 2205
        np.testing.assert_array_equal(newest.left, whole.left[-3 * 2205:])
        _, lost = await port(since=whole.index - 20)  # the port holds 8 chunks: 12 were lost
        assert lost == 12


def test_fast_json_falls_back_whenever_it_cannot_be_sure() -> None:
    arrays = {"left": np.dtype("<i4")}
    padding = " " * (1 << 16)  # above the size where the fast path applies
    cases = [
        {"P": {"meta": {"left": [9]}, "left": [3, 4], "pad": padding}},  # a nested "left" comes first
        {"P": {"left": [1, None, 3], "pad": padding}},                # null in the array
        {"P": {"left": [1, 2**40], "pad": padding}},                  # out of the dtype's range
        {"P": {"left": [[1], [2]], "pad": padding}},                  # nested arrays
    ]
    for case in cases:
        body = orjson.dumps(case)
        parsed = loads_with_arrays(body, "P", arrays)
        assert parsed == orjson.loads(body)  # the plain parse: lists, not arrays
        assert isinstance(parsed["P"]["left"], list)
    fast = loads_with_arrays(orjson.dumps({"P": {"left": list(range(-5, 5)), "pad": padding}}), "P", arrays)
    assert isinstance(fast["P"]["left"], np.ndarray) and fast["P"]["left"].tolist() == list(range(-5, 5))
