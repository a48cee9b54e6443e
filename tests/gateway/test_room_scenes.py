"""Issue 30, acceptance 2 and 3: a scene file with a room, three talkers (one a WAV file) and a SOFA head,
captured by ``capture``, ``kemarcapture`` and ``bass`` over the protocol; a SOFA file that is no head is refused
by name and the gateway goes on.

Every step is an HTTP GET to a real gateway; the host's clock is a ``ManualClock`` run until what the test
waits for has come. The captured samples equal the same scene rendered offline, chunk by chunk.
"""

from __future__ import annotations

import json
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import aiohttp
import numpy as np
import pytest
import soundfile

from aiogenomix.components.audio import RoomSceneRenderer, load_scene
from aiogenomix.components.bass import Bass
from aiogenomix.components.binaural import snowman_hrirs, speech_like, write_sofa
from aiogenomix.components.capture import Capture
from aiogenomix.components.core import ComponentHost, HostSettings, ManualClock
from aiogenomix.components.kemarcapture import KemarCapture
from aiogenomix.gateway import GatewayConfig, serve

RATE, FPC, CHUNKS = 44_100, 2205, 8
FACTORIES = {"capture": Capture, "kemarcapture": KemarCapture, "bass": Bass}


@pytest.fixture
def sounds(tmp_path: Path) -> Path:
    """The directory the gateway allows: a scene, a talker's WAV file (16 kHz, resampled) and the snowman's SOFA."""
    folder = tmp_path / "sounds"
    folder.mkdir()
    soundfile.write(folder / "talker.wav", 0.3 * speech_like(2.0, 16_000.0, np.random.default_rng(3), voice="child"),
                    16_000)
    write_sofa(snowman_hrirs(), folder / "snowman.sofa")
    scene = {
        "seed": 11, "hrtf": "snowman.sofa", "noise_floor": -90,
        "room": {"dimensions": [6, 4, 3], "rt60": [0.6, 0.6, 0.5, 0.45, 0.4, 0.35, 0.3]},
        "listener": {"x": 3.0, "y": 2.0, "z": 1.5, "facing": 10.0},
        "sources": [
            {"type": "speech", "azimuth": 40, "distance": 1.5, "level": -20},
            {"type": "speech", "azimuth": -70, "distance": 2.0, "level": -23, "voice": "female", "onset": 0.05},
            {"type": "file", "file": "talker.wav", "position": [1.0, 3.2, 1.6], "level": -20, "loop": False},
        ],
    }
    (folder / "three_talkers.json").write_text(json.dumps(scene))
    (folder / "not_a_head.json").write_text(json.dumps(scene | {"hrtf": "talker.wav"}))
    return folder


@pytest.fixture
async def gateway(sounds: Path) -> AsyncIterator[tuple[aiohttp.ClientSession, ManualClock]]:
    clock = ManualClock()
    settings = HostSettings(audio_socket_port=0, audio_files=(str(sounds),))
    async with ComponentHost(clock=clock, settings=settings, factories=FACTORIES) as host, \
            serve(GatewayConfig.of(port=0), host) as url, aiohttp.ClientSession(url) as http:
        yield http, clock


async def get(http: aiohttp.ClientSession, path: str, inputs: dict[str, Any] | None = None) -> Any:
    params = {"input": json.dumps(inputs)} if inputs is not None else {}
    async with http.get(path, params=params) as reply:
        assert reply.status == 200, await reply.text()
        return await reply.json()


async def watched(http: aiohttp.ClientSession, path: str, port: str, frames: int) -> np.ndarray:
    """The frames a watch of *port* from its start gives, until *frames* have come: ``(frames, 2)``."""
    left: list[int] = []
    right: list[int] = []
    async with http.get(path, params={"since": "0"}) as watching:
        async for line in watching.content:
            if not line.startswith(b"data: "):
                continue
            event = json.loads(line[6:])
            data = event[port]
            if data is None or not data.get("left"):
                continue
            assert event.get("lost", 0) == 0
            left += data["left"]
            right += data["right"]
            if len(left) >= frames:
                break
    return np.stack([left[:frames], right[:frames]], axis=1)


def reference(sounds: Path, chunks: int, head: float = 0.0) -> np.ndarray:
    renderer = RoomSceneRenderer(load_scene(sounds / "three_talkers.json"), RATE, roots=[str(sounds)])
    return np.concatenate([renderer.render(FPC, head) for _ in range(chunks)])


@pytest.mark.parametrize("component", ["capture", "kemarcapture", "bass"])
async def test_a_room_with_three_talkers_and_a_sofa_head_is_captured_over_the_protocol(
        gateway: tuple[aiohttp.ClientSession, ManualClock], sounds: Path, component: str) -> None:
    http, clock = gateway
    async with http.get(f"/load/{component}") as reply:
        assert await reply.text() == component
    device = f"sim:{sounds / 'three_talkers.json'}"
    if component == "bass":
        started = await get(http, "/module/bass/send/Acquire", {"device": device, "sampleRate": RATE,
                                                                "nFramesPerChunk": FPC, "nChunksOnPort": 20})
        path, port = "/module/bass/watch/Audio", "Audio"
    else:
        started = await get(http, f"/module/{component}/send/StartCapture",
                            {"device": device, "transfer_rate": RATE, "chunk_time": 50, "Port_chunks": 20})
        path, port = f"/module/{component}/watch/Port", "Port"
    assert started["status"] == "sent"
    ears = await clock.run_until(watched(http, path, port, CHUNKS * FPC))
    stop = "Stop" if component == "bass" else "StopCapture"
    await get(http, f"/module/{component}/send/{stop}")
    expected = reference(sounds, CHUNKS)
    assert np.abs(ears).max() > 1e6                       # sound, at -20 dB 1.5 m away
    assert np.array_equal(ears, expected)


async def test_a_sofa_file_that_is_no_head_is_refused_by_name_and_the_gateway_goes_on(
        gateway: tuple[aiohttp.ClientSession, ManualClock], sounds: Path) -> None:
    http, clock = gateway
    async with http.get("/load/capture") as reply:
        assert reply.status == 200
    refused = await get(http, "/module/capture/send/StartCapture",
                        {"device": f"sim:{sounds / 'not_a_head.json'}", "Port_chunks": 4})
    ended = await clock.run_until(get(http, f"/module/capture/wait/{refused['id']}"))
    assert ended["status"] == "error" and ended["exception"]["ex"] == "::capture::DEVICE_ERROR"
    assert "hrtf" in ended["exception"]["detail"]["what"] and "not a SOFA file" in ended["exception"]["detail"]["what"]
    async with http.get(f"/module/capture/clean/{refused['id']}") as reply:
        assert reply.status == 200
    # The gateway and the component go on: the good scene captures.
    await get(http, "/module/capture/send/StartCapture",
              {"device": f"sim:{sounds / 'three_talkers.json'}", "transfer_rate": RATE, "Port_chunks": 20})
    ears = await clock.run_until(watched(http, "/module/capture/watch/Port", "Port", 2 * FPC))
    assert np.array_equal(ears, reference(sounds, 2))
