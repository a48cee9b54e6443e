"""Issue 31, acceptance 3: FaceSource with two talkers faces the one asked for, the loudest or the nearest an azimuth.

On the simulated ``kemarcapture`` and on ``morse_kemar`` in the virtual world (the same scene file: a room of
RT60 0.4 s, two speech-like talkers, heard from the head each turns), on simulated time.
"""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import pytest

from aiogenomix.components.core import ComponentHost, VirtualClock

from .conftest import done

#: The talkers' room azimuths, the first 6 dB louder.
TALKERS = (30.0, -55.0)


def two_talkers(directory: Path) -> str:
    path = directory / "two_talkers.json"
    path.write_text(json.dumps({
        "seed": 5, "diffuse_level": -30, "noise_floor": -80,
        "room": {"dimensions": [7.0, 5.5, 3.0], "rt60": 0.4},
        "listener": {"x": 3.6, "y": 2.6, "z": 1.5, "facing": 0.0},
        "sources": [{"type": "speech", "azimuth": TALKERS[0], "distance": 1.5, "level": -17, "onset": 1.2},
                    {"type": "speech", "azimuth": TALKERS[1], "distance": 1.5, "level": -23, "onset": 1.2,
                     "voice": "female"}]}))
    return f"sim:{path}"


@pytest.mark.parametrize(("inputs", "faced"), [
    ({}, TALKERS[0]),                                                      # the loudest by default
    ({"target": "::binauloc::NEAREST", "azimuth": -90.0}, TALKERS[1]),     # the one nearest -90 degrees
    ({"target": "::binauloc::NEAREST", "azimuth": 10.0}, TALKERS[0]),
])
async def test_kemarcapture_faces_the_talker_asked_for(rig: ComponentHost, tmp_path: Path, inputs: dict,
                                                       faced: float) -> None:
    merged, binauloc = await rig.load("kemarcapture"), await rig.load("binauloc")
    await done(merged, "Homing")
    await done(binauloc, "connect_port", {"local": "KemarPort", "remote": "kemarcapture/Port"})
    began = rig.clock.now()
    capturing = await merged.send("StartCapture", {"device": two_talkers(tmp_path)})
    await done(binauloc, "LearnNoise", {"seconds": 1.0})                  # the talkers start at 1.2 s
    await rig.clock.sleep_until(began + 1.3)
    found = (await done(binauloc, "FaceSource", inputs))["source"]
    await done(merged, "StopCapture")
    await capturing.ended.wait()
    assert found["faced"] == 1 and found["turns"] >= 1
    assert math.degrees(found["roomAzimuth"]) == pytest.approx(faced, abs=5.0), found
    assert math.degrees(found["headAzimuth"]) == pytest.approx(math.degrees(found["roomAzimuth"]), abs=0.2)
    # Both talkers are among the sources found, each within 5 degrees.
    rooms = [math.degrees(s["roomAzimuth"]) for s in found["sources"]]
    assert all(min(abs(math.remainder(r - t, 360.0)) for r in rooms) <= 5.0 for t in TALKERS), rooms


@pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason="mujoco is not installed")
async def test_morse_kemar_faces_the_talker_asked_for(tmp_path: Path) -> None:
    # The virtual KEMAR of the world turns; the capture hears the two talkers of a scene file (which wins
    # over the world's markers) from its head.
    async with ComponentHost(clock=VirtualClock()) as host:
        await host.load("world", ["-size", "32x32", "-rate", "2"])
        await host.load("morse_kemar")
        capture, binauloc = await host.load("capture"), await host.load("binauloc")
        await done(binauloc, "connect_port", {"local": "CapturePort", "remote": "capture/Port"})
        began = host.clock.now()
        capturing = await capture.send("StartCapture", {"device": two_talkers(tmp_path)})
        await done(binauloc, "LearnNoise", {"seconds": 1.0})
        await host.clock.sleep_until(began + 1.3)
        for inputs, faced in (({}, TALKERS[0]), ({"target": "::binauloc::NEAREST", "azimuth": -90.0}, TALKERS[1])):
            found = (await done(binauloc, "FaceSource", inputs))["source"]
            assert found["faced"] == 1, found
            assert math.degrees(found["roomAzimuth"]) == pytest.approx(faced, abs=5.0), found
            assert math.degrees(found["headAzimuth"]) == pytest.approx(math.degrees(found["roomAzimuth"]), abs=2.0)
        await done(capture, "StopCapture")
        await capturing.ended.wait()
