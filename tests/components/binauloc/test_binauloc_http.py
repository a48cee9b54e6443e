"""Issue 25, acceptance 2 (first half): binauloc on bass/Audio over the protocol, as the Two!Ears scripts drove it.

``binauloc.connect_port('Audio', 'bass/Audio'); binauloc.Setup(24414, 5000, 1024, 512, HANNING, 10);
binauloc.LearnNoise(2); binauloc.LocalizeSources(...)``, then ``binauloc.Azimuths()`` read while it
runs: every step an HTTP GET to a real gateway, the estimates as a watch of ``Azimuths`` gives them.
The host's clock is a ``ManualClock`` that the test runs until what it waits for has come (the end of
LearnNoise, the next estimate), so the source, the noise and the estimates meet where the test says.
"""

from __future__ import annotations

import json
import math
import statistics
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import aiohttp
import pytest

from aiogenomix.components.core import ComponentHost, HostSettings, ManualClock
from aiogenomix.gateway import GatewayConfig, serve

from .conftest import FACTORIES, source_scene

SUMMER_SCHOOL_SETUP = {"sampleRate": 24414, "maxFrequency": 5000, "frameSize": 1024, "overlap": 512,
                       "window": "::binauloc::HANNING", "smoothing": 10}


@pytest.fixture
async def gateway(tmp_path: Path) -> AsyncIterator[tuple[aiohttp.ClientSession, ManualClock]]:
    clock = ManualClock()
    settings = HostSettings(audio_socket_port=0, audio_files=(str(tmp_path),))
    async with ComponentHost(clock=clock, settings=settings, factories=FACTORIES) as host, \
            serve(GatewayConfig.of(port=0), host) as url, aiohttp.ClientSession(url) as http:
        yield http, clock


async def get(http: aiohttp.ClientSession, path: str, inputs: dict[str, Any] | None = None) -> Any:
    params = {"input": json.dumps(inputs)} if inputs is not None else {}
    async with http.get(path, params=params) as reply:
        assert reply.status == 200, await reply.text()
        return await reply.json()


async def test_binauloc_on_bass_over_http_reports_62_5_degrees(gateway: tuple[aiohttp.ClientSession, ManualClock],
                                                              tmp_path: Path) -> None:
    http, clock = gateway
    for name in ("bass", "binauloc"):
        async with http.get(f"/load/{name}") as reply:
            assert await reply.text() == name
    connect = await get(http, "/module/binauloc/send/connect_port", {"local": "Audio", "remote": "bass/Audio"})
    assert connect["status"] == "done"
    setup = await get(http, "/module/binauloc/send/Setup", SUMMER_SCHOOL_SETUP)
    assert setup["status"] == "done"
    # A talker at 62.5° (lateral, not on a measured direction) starts after 2.5 s of a diffuse field 20 dB below.
    device = source_scene(tmp_path, 62.5, seed=25, kind="speech", onset=2.5, snr=20.0)
    learning = await get(http, "/module/binauloc/send/LearnNoise", {"seconds": 2})
    await get(http, "/module/bass/send/Acquire", {"device": device, "sampleRate": 24414, "nFramesPerChunk": 4096,
                                                   "nChunksOnPort": 20})
    # Simulated time runs, deadline after deadline, until the request has ended (the reply of wait).
    learnt = await clock.run_until(get(http, f"/module/binauloc/wait/{learning['id']}"))
    assert learnt["status"] == "done" and learnt["output"]["nFrames"] >= 90
    estimates: list[dict[str, Any]] = []
    async with http.get("/module/binauloc/watch/Azimuths") as watching:
        events = _events(watching)
        assert (await anext(events))["Azimuths"]["estimate"] == 0  # the current data comes first
        localizing = await get(http, "/module/binauloc/send/LocalizeSources", {"nEstimates": 20})
        while len(estimates) < 20:
            # Each estimate as it is published (one a bass chunk at most: never two before the watch sends one).
            event = await clock.run_until(anext(events))
            assert event["lost"] == 0
            estimates.append(event["Azimuths"])
    assert [e["estimate"] for e in estimates] == list(range(1, 21))
    ended = await get(http, f"/module/binauloc/wait/{localizing['id']}")
    assert ended["status"] == "done" and ended["output"] == {"nEstimates": 20}
    # The estimates resting on the learnt noise alone (the analysis starts where LearnNoise ended, at 2 s; the
    # talker at 2.5 s) detect nothing: no source, confidence 0 (they once named one ahead, up to 0.999 sure).
    alone = [e for e in estimates if e["frameIndex"] < 2.5 * 24414]
    assert alone and all(e["nSources"] == 0 and e["azimuth"] is None and e["confidence"] == 0 for e in alone)
    talking = [e for e in estimates if e["frameIndex"] > 2.5 * 24414 + 1024]
    assert len(talking) >= 17 and all(e["nSources"] >= 1 for e in talking)
    laterals = [lateral(e["azimuth"]) for e in talking]
    assert abs(statistics.median(laterals) - 62.5) <= 5.0, laterals
    # The sure estimates of the talker's audio say where it is.
    sure = [value for value, e in zip(laterals, talking, strict=True) if e["confidence"] >= 0.9]
    assert sure and all(abs(value - 62.5) <= 5.0 for value in sure), laterals
    assert all(e["headAzimuth"] is None for e in estimates)          # no head: NaN travels as null
    assert len(estimates[-1]["logLikelihood"]) == 360


async def _events(reply: aiohttp.ClientResponse) -> AsyncIterator[dict[str, Any]]:
    """The ``port`` events of a watch stream (genomix's form: close-delimited, ``data:`` lines)."""
    async for line in reply.content:
        if line.startswith(b"data: "):
            yield json.loads(line[6:])


def lateral(radians: float) -> float:
    return math.degrees(math.asin(math.sin(radians)))
