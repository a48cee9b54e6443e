"""Issue 31, acceptance 2: binauloc on bass/Audio of two talkers in a reverberant room, read slowly by index.

Every step is an HTTP GET to a real gateway whose host runs on a ``ManualClock``: ``bass`` captures a scene
file (a 8 x 6 x 3.2 m room of RT60 0.6 s, two speech-like talkers starting after 2.5 s of the room's noise),
``binauloc`` learns the noise, then localises two sources an estimate a second. The client reads the
estimate history once a second of the rig's time with ``since=`` the last estimate it had, as a client
polling over a busy network would: it gets every estimate once, numbered without a gap, and the estimates
name both talkers within 5 degrees.
"""

from __future__ import annotations

import json
import math
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import aiohttp
import numpy as np
import pytest

from aiogenomix.components.core import ComponentHost, HostSettings, ManualClock
from aiogenomix.gateway import GatewayConfig, serve

from .conftest import FACTORIES

TALKERS = (35.0, -80.0)


@pytest.fixture
async def gateway(tmp_path: Path) -> AsyncIterator[tuple[aiohttp.ClientSession, ManualClock]]:
    clock = ManualClock()
    settings = HostSettings(audio_socket_port=0, audio_files=(str(tmp_path),))
    async with ComponentHost(clock=clock, settings=settings, factories=FACTORIES) as host, \
            serve(GatewayConfig.of(port=0), host) as url, aiohttp.ClientSession(url) as http:
        yield http, clock


async def get(http: aiohttp.ClientSession, path: str, inputs: dict[str, Any] | None = None,
              **query: str) -> Any:
    params = {"input": json.dumps(inputs)} if inputs is not None else {}
    async with http.get(path, params=params | query) as reply:
        assert reply.status == 200, await reply.text()
        return await reply.json()


def two_talkers(directory: Path) -> str:
    path = directory / "two_talkers.json"
    path.write_text(json.dumps({
        "seed": 31, "diffuse_level": -30, "noise_floor": -80,
        "room": {"dimensions": [8.0, 6.0, 3.2], "rt60": 0.6},
        "listener": {"x": 4.2, "y": 2.8, "z": 1.5, "facing": 0.0},
        "sources": [{"type": "speech", "azimuth": TALKERS[0], "distance": 1.6, "level": -20, "onset": 2.5},
                    {"type": "speech", "azimuth": TALKERS[1], "distance": 1.4, "level": -20, "onset": 2.5,
                     "voice": "female"}]}))
    return f"sim:{path}"


async def test_two_talkers_in_a_room_read_slowly_by_index(gateway: tuple[aiohttp.ClientSession, ManualClock],
                                                          tmp_path: Path) -> None:
    http, clock = gateway
    for name in ("bass", "binauloc"):
        async with http.get(f"/load/{name}") as reply:
            assert await reply.text() == name
    assert (await get(http, "/module/binauloc/send/connect_port", {"local": "Audio", "remote": "bass/Audio"}))[
        "status"] == "done"
    # An estimate every 47 frames of 1024, 512 apart: a second of audio.
    setup = {"sampleRate": 24414, "maxFrequency": 5000, "frameSize": 1024, "overlap": 512,
             "window": "::binauloc::HANNING", "smoothing": 47}
    assert (await get(http, "/module/binauloc/send/Setup", setup))["status"] == "done"
    learning = await get(http, "/module/binauloc/send/LearnNoise", {"seconds": 2})
    await get(http, "/module/bass/send/Acquire", {"device": two_talkers(tmp_path), "sampleRate": 24414,
                                                   "nFramesPerChunk": 4096, "nChunksOnPort": 20})
    assert (await clock.run_until(get(http, f"/module/binauloc/wait/{learning['id']}")))["status"] == "done"
    first = await get(http, "/module/binauloc/read/Estimates")
    since = first["Estimates"]["last"]
    localizing = await get(http, "/module/binauloc/send/LocalizeSources", {"nEstimates": 8, "nSources": 2})
    numbers: list[int] = []
    sources: list[list[float]] = []
    while len(numbers) < 8:
        # One read a second of the rig's time, asking for the estimates after the last one had.
        await clock.advance(1.0)
        read = await get(http, "/module/binauloc/read/Estimates", since=str(since))
        assert read["lost"] == 0
        estimates = read["Estimates"]
        count = estimates["nEstimates"]
        numbers += estimates["estimate"]
        for k in range(count):
            # bass carries no head: the head frame it is (the head faces 0 degrees, the room's).
            assert estimates["headAzimuth"][k] is None
            sources.append([math.degrees(a) for a in estimates["azimuth"][6 * k:6 * k + estimates["nSources"][k]]])
        since = estimates["last"]
    assert numbers == list(range(first["Estimates"]["last"] + 1, first["Estimates"]["last"] + 9))
    ended = await clock.run_until(get(http, f"/module/binauloc/wait/{localizing['id']}"))
    assert ended["status"] == "done" and ended["output"] == {"nEstimates": 8}
    assert len(sources) == 8 and all(len(estimate) == 2 for estimate in sources)
    for talker in TALKERS:
        errors = [min(abs(math.remainder(found - talker, 360.0)) for found in estimate) for estimate in sources]
        # Each talker is within 5 degrees in at least six estimates of eight (a second of speech each).
        assert np.sum(np.array(errors) <= 5.0) >= 6 and np.median(errors) <= 2.0, (talker, sources)
    latest = (await get(http, "/module/binauloc/read/Azimuths"))["Azimuths"]
    assert latest["nSources"] == 2 and latest["index"] == numbers[-1] and len(latest["sources"]) == 2
