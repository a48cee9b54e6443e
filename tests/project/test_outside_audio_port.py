"""Issue 33: an outside component's own audio port is recorded, exported, replayed, shown live and localised.

``Ears`` is a component of another package (``outside_package/outside_ears``): its port type is its
own (``ears::block``: 16-bit samples, interleaved, numbered by chunk), no table of ours names it,
and its declaration says what it carries (``AudioStream``).  The recorder records it as audio with its frame indexes,
``aiogenomix-record export`` writes it as a WAV (the same samples), a capture plays it again
(``mcap:PATH``), the live view shows it as
``foxglove.RawAudio``, and ``binauloc``'s one audio in port reads it and finds the source.  The rig
runs on a VirtualClock: the scene, the chunks and the estimates meet where the test says.
"""

from __future__ import annotations

import importlib.util
import math
import statistics
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import soundfile

from aiogenomix.components.audio import open_backend
from aiogenomix.components.binauloc import Binauloc
from aiogenomix.components.core import Component, ComponentHost, HostSettings, ManualClock, VirtualClock
from aiogenomix.components.recorder import Recorder
from aiogenomix.record import main as record_main

from .outside_package.outside_ears import Ears

RATE, FRAMES = 44100, 2205


def scene(directory: Path, azimuth: float) -> str:
    """A ``sim:`` device: one noise source at *azimuth* (degrees) in a diffuse field 20 dB below it."""
    path = directory / "scene.json"
    path.write_text('{"seed": 7, "diffuse_level": -20, "noise_floor": -80, "sources": '
                    f'[{{"type": "noise", "azimuth": {azimuth}, "level": -26, "onset": 0}}]}}')
    return f"sim:{path}"


@pytest.fixture
async def rig(tmp_path: Path) -> AsyncIterator[ComponentHost]:
    settings = HostSettings(audio_socket_port=0, record_dirs=(str(tmp_path),), audio_files=(str(tmp_path),))
    async with ComponentHost(clock=VirtualClock(), settings=settings,
                             factories={"ears": Ears, "binauloc": Binauloc, "recorder": Recorder}) as host:
        yield host


async def done(component: Component, service: str, inputs: dict[str, Any] | None = None) -> dict[str, Any]:
    request = await component.send(service, inputs or {})
    await request.ended.wait()
    assert request.status == "done", (service, request.exception)
    return dict(request.output or {})


async def test_an_outside_audio_port_is_recorded_exported_replayed_and_localised(rig: ComponentHost,
                                                                                 tmp_path: Path) -> None:
    ears, binauloc, recorder = await rig.load("ears"), await rig.load("binauloc"), await rig.load("recorder")
    assert isinstance(ears, Ears)
    described = next(p for p in ears.description()["ports"] if p["name"] == "Ears")
    assert described["type"]["carries"]["kind"] == "audio" and described["type"]["carries"]["sample"] == "int16"
    await done(binauloc, "connect_port", {"local": "Audio", "remote": "ears/Ears"})
    await done(binauloc, "Setup", {"sampleRate": RATE})
    recording = await recorder.send("Start", {"path": "ears.mcap", "ports": ["ears/Ears"]})
    localizing = await binauloc.send("LocalizeSources", {"nEstimates": 12})
    await done(ears, "Listen", {"device": scene(tmp_path, 50.0), "seconds": 3.0})
    await localizing.ended.wait()
    assert localizing.status == "done", localizing.exception
    await done(recorder, "Stop")
    await recording.ended.wait()
    assert recording.status == "done", recording.exception

    # Localised: binauloc read the outside port by its kind and found the source where it is.
    estimates, lost = binauloc.Estimates.read().since(0)
    strongest = estimates.azimuth[::6]   # each estimate's sources, strongest first, six places each
    azimuths = [math.degrees(math.asin(math.sin(a))) for a in strongest]
    assert lost == 0 and estimates.nEstimates == 12
    assert len(azimuths) == 12 and abs(statistics.median(azimuths) - 50.0) <= 2.0, azimuths
    # Recorded as audio and exported as a WAV: every sample the ears published, at their rate.
    heard = np.concatenate(ears.heard).reshape(-1, 2).astype(np.int32) << 16
    assert record_main(["export", str(tmp_path / "ears.mcap"), "-o", str(tmp_path / "out")]) == 0
    wav, rate = soundfile.read(tmp_path / "out" / "ears_Ears.wav", dtype="int32")
    assert rate == RATE and len(heard) == 60 * FRAMES
    np.testing.assert_array_equal(wav, heard)
    # Played again as a capture device (mcap:PATH): the same frames.
    clock = ManualClock()
    delivered = []
    async with open_backend("mcap:ears.mcap", RATE, FRAMES, clock, roots=(str(tmp_path),)) as backend:
        while (chunk := await clock.run_until(backend.read())) is not None:
            delivered.append(chunk.frames)
    np.testing.assert_array_equal(np.concatenate(delivered), heard)


@pytest.mark.skipif(importlib.util.find_spec("foxglove") is None, reason="needs the Foxglove SDK")
async def test_an_outside_audio_port_is_shown_live_as_raw_audio(rig: ComponentHost, tmp_path: Path) -> None:
    from aiogenomix.gateway._access import AccessPolicy
    from aiogenomix.gateway._door import Door
    from aiogenomix.gateway._foxglove import FoxgloveView

    from ..gateway.test_foxglove_conversions import shown_messages

    ears = await rig.load("ears")
    assert isinstance(ears, Ears)
    shown = FoxgloveView("127.0.0.1", 0, Door(AccessPolicy(), None), clock=rig.clock)
    await shown.start(rig.instances)
    try:
        listening = await ears.send("Listen", {"device": scene(tmp_path, 50.0), "seconds": 30.0})
        _, audio = (await shown_messages(shown, ["/ears/Ears"]))["/ears/Ears"]
        await ears.interrupt(listening, by="test")
    finally:
        await shown.stop()
    assert (audio.format, audio.sample_rate, audio.number_of_channels) == ("pcm-s16", RATE, 2)
    samples = np.frombuffer(audio.data, "<i2")
    assert len(samples) == 2 * FRAMES
    assert any(np.array_equal(samples, chunk) for chunk in ears.heard)   # a chunk the ears heard, unchanged
