"""binauloc in-process: its interface, the ports it reads, estimates by frame index, head turns for front and back.

Everything runs on simulated time (a ``VirtualClock``): the scene, the head and the localiser are
where these tests expect them however busy the machine.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from aiogenomix.components.binauloc import Binauloc
from aiogenomix.components.core import ComponentHost
from aiogenomix.components.core.runtime import NoSuchRequest, describe

from .conftest import done, source_scene


def lateral(radians: float) -> float:
    """The lateral angle of an azimuth, degrees (front and back folded)."""
    return math.degrees(math.asin(math.sin(radians)))


async def test_the_interface_is_the_two_ears_one(rig: ComponentHost) -> None:
    info = describe(await rig.load("binauloc"))
    services = {s["name"]: s for s in info["services"]}
    assert [p["name"] for p in services["Setup"]["parameters"]] == [
        "sampleRate", "maxFrequency", "frameSize", "overlap", "window", "smoothing"]
    window = services["Setup"]["parameters"][4]
    assert window["type"]["name"] == "::binauloc::window" and window["default"] == "::binauloc::HANNING"
    assert {"LearnNoise", "LocalizeSources", "FaceSource", "Stop", "connect_port"} <= set(services)
    assert services["LocalizeSources"]["kind"] == "activity"
    ports = {p["name"]: p for p in info["ports"]}
    assert [(n, ports[n]["dir"], ports[n]["type"]["name"]) for n in ("Audio", "CapturePort", "KemarPort")] == [
        ("Audio", "in", "::binaudio::portStruct"), ("CapturePort", "in", "::capture::port_t"),
        ("KemarPort", "in", "::kemarcapture::port_t")]
    members = [m["name"] for m in ports["Azimuths"]["type"]["members"]]
    assert members[:3] == ["azimuth", "confidence", "frameIndex"] and "roomAzimuth" in members


@pytest.mark.parametrize(("inputs", "what"), [
    ({"overlap": 1024}, "overlap"), ({"frameSize": 1000, "overlap": 500}, "power of two"),
    ({"maxFrequency": 50.0}, "frequency"), ({"smoothing": 0}, "frame"),
    ({"frameSize": 1 << 30, "overlap": 0}, "at most"), ({"smoothing": 100_000}, "at most"),
    ({"maxFrequency": float("nan")}, "frequency"),
])
async def test_setups_that_make_no_analysis_are_refused(rig: ComponentHost, inputs: dict, what: str) -> None:
    binauloc = await rig.load("binauloc")
    request = await binauloc.send("Setup", inputs)
    await request.ended.wait()
    assert request.exception is not None and request.exception["ex"] == "::binauloc::e_setup"
    assert what in request.exception["detail"]["what"]


async def test_a_port_of_another_type_is_refused_with_the_in_port_that_reads_it(rig: ComponentHost) -> None:
    binauloc = await rig.load("binauloc")
    await rig.load("capture")
    request = await binauloc.send("connect_port", {"local": "Audio", "remote": "capture/Port"})
    assert request.exception == {"ex": "::genom::port_io", "detail": {
        "what": "binauloc/Audio reads ::binaudio::portStruct, capture/Port publishes ::capture::port_t; "
                "CapturePort of binauloc reads it"}}
    nothing = await binauloc.send("LocalizeSources")
    await nothing.ended.wait()
    assert nothing.exception is not None and nothing.exception["ex"] == "::binauloc::e_noData"
    assert "connect Audio to bass/Audio" in nothing.exception["detail"]["what"]


async def test_bass_frames_are_read_by_index_without_a_gap(rig: ComponentHost, tmp_path: Path) -> None:
    bass, binauloc = await rig.load("bass"), await rig.load("binauloc")
    await done(binauloc, "connect_port", {"local": "Audio", "remote": "bass/Audio"})
    await done(binauloc, "Setup", {"sampleRate": 24414, "smoothing": 10})
    acquiring = await bass.send("Acquire", {"device": source_scene(tmp_path, 62.5, seed=1, onset=0.0),
                                            "sampleRate": 24414, "nFramesPerChunk": 4096, "nChunksOnPort": 20})
    frames: list[int] = []
    localizing = await binauloc.send("LocalizeSources", {"nEstimates": 12})
    version = binauloc.Azimuths.version
    while localizing.running:
        version = await binauloc.Azimuths.wait_published(version)
        frames.append(binauloc.Azimuths.read().frameIndex)
    assert localizing.output == {"nEstimates": 12}
    # Ten frames of 1024 every 512 samples an estimate: each one ends 5120 frames after the last,
    # across chunks of 4096 frames (an estimate per publication or none, never a frame skipped).
    assert np.all(np.diff(frames) == 5120) and frames[0] % 4096 != 0
    estimate = binauloc.Azimuths.read()
    assert estimate.estimate == 12 and estimate.nFrames == 10 and len(estimate.logLikelihood) == 360
    assert math.isnan(estimate.headAzimuth) and math.isnan(estimate.roomAzimuth)   # no head: head frame only
    await done(bass, "Stop")
    await acquiring.ended.wait()


async def test_a_setup_at_another_rate_than_the_port_is_refused(rig: ComponentHost, tmp_path: Path) -> None:
    bass, binauloc = await rig.load("bass"), await rig.load("binauloc")
    await done(binauloc, "connect_port", {"local": "Audio", "remote": "bass/Audio"})
    await done(binauloc, "Setup", {"sampleRate": 24414})
    await bass.send("Acquire", {"device": "sim"})             # 44,100 Hz
    request = await binauloc.send("LocalizeSources", {"nEstimates": 1})
    await request.ended.wait()
    assert request.exception == {"ex": "::binauloc::e_rate", "detail": {"setup": 24414, "port": 44100}}


async def test_estimates_follow_a_turning_head_with_kemarcaptures_positions(rig: ComponentHost,
                                                                           tmp_path: Path) -> None:
    merged, binauloc = await rig.load("kemarcapture"), await rig.load("binauloc")
    await done(merged, "Homing")
    await done(binauloc, "connect_port", {"local": "KemarPort", "remote": "kemarcapture/Port"})
    await merged.send("StartCapture", {"device": source_scene(tmp_path, 100.0, seed=2, onset=0.0, snr=20.0)})
    localizing = await binauloc.send("LocalizeSources")
    estimates = []
    version = binauloc.Azimuths.version
    moving = await merged.send("MoveAbsolutePosition", {"target": 60.0, "velocity": 45.0})
    while moving.running:
        version = await binauloc.Azimuths.wait_published(version)
        estimates.append(binauloc.Azimuths.read())
    assert moving.status == "done"
    await done(binauloc, "Stop")
    await localizing.ended.wait()
    turning = [e for e in estimates if 5.0 < math.degrees(e.headAzimuth) < 55.0]
    assert len(turning) >= 6
    for estimate in turning:
        # In the head frame, the source moves as the head turns; in the room, it stays at 100°.
        assert abs(math.degrees(estimate.azimuth + estimate.headAzimuth) - 100.0) < 5.0
        assert math.degrees(estimate.roomAzimuth) == pytest.approx(100.0, abs=5.0)


async def test_capture_with_the_kemar_head_gets_the_head_read_as_the_audio_arrives(rig: ComponentHost,
                                                                                  tmp_path: Path) -> None:
    kemar, capture, binauloc = await rig.load("kemar"), await rig.load("capture"), await rig.load("binauloc")
    await done(kemar, "Homing")
    await done(kemar, "MoveAbsolutePosition", {"target": -20.0})
    await done(binauloc, "connect_port", {"local": "CapturePort", "remote": "capture/Port"})
    await capture.send("StartCapture", {"device": source_scene(tmp_path, 40.0, seed=3, onset=0.0)})
    output = await done(binauloc, "LocalizeSources", {"nEstimates": 4})
    assert output == {"nEstimates": 4}
    estimate = binauloc.Azimuths.read()
    assert math.degrees(estimate.headAzimuth) == pytest.approx(-20.0, abs=0.1)
    assert math.degrees(estimate.azimuth) == pytest.approx(60.0, abs=4.0)
    assert math.degrees(estimate.roomAzimuth) == pytest.approx(40.0, abs=4.0)


async def test_face_source_needs_a_head(rig: ComponentHost) -> None:
    binauloc = await rig.load("binauloc")
    request = await binauloc.send("FaceSource")
    await request.ended.wait()
    assert request.exception is not None and request.exception["ex"] == "::binauloc::e_noHead"


async def test_head_turns_tell_32_5_from_147_5_degrees_in_every_seeded_run(rig: ComponentHost,
                                                                          tmp_path: Path) -> None:
    """Issue 25, acceptance 2 (second half): kemarcapture, rotation allowed, a seeded batch on simulated time."""
    merged, binauloc = await rig.load("kemarcapture"), await rig.load("binauloc")
    assert isinstance(binauloc, Binauloc)
    await done(merged, "Homing")
    await done(binauloc, "connect_port", {"local": "KemarPort", "remote": "kemarcapture/Port"})
    clock = rig.clock
    for seed in range(3):
        for azimuth in (32.5, 147.5):
            start = float(np.random.default_rng([seed, int(azimuth)]).uniform(-10.0, 10.0))   # off the grid
            await done(merged, "MoveAbsolutePosition", {"target": start})
            began = clock.now()
            device = source_scene(tmp_path, azimuth, seed=seed, kind="speech", onset=1.5, snr=5.0)
            capturing = await merged.send("StartCapture", {"device": device})
            await done(binauloc, "LearnNoise", {"seconds": 1.0})      # the source starts at 1.5 s
            await clock.sleep_until(began + 1.7)
            found = (await done(binauloc, "FaceSource"))["source"]
            await done(merged, "StopCapture")
            await capturing.ended.wait()
            room = math.degrees(found["roomAzimuth"])
            assert abs(room - azimuth) < 6.0, (seed, azimuth, found)            # not its mirror image
            assert found["confidence"] > 0.9 and found["turns"] >= 1
            head = math.degrees(found["headAzimuth"])
            if azimuth < 90:
                assert found["faced"] == 1 and head == pytest.approx(room, abs=0.2)
            else:   # behind: the neck stops at its limit, on the source's side
                assert found["faced"] == 0 and head == pytest.approx(89.5, abs=0.2)
            assert binauloc.Source.read().roomAzimuth == found["roomAzimuth"]


async def test_stop_while_the_head_turns_stops_the_head(rig: ComponentHost, tmp_path: Path) -> None:
    merged, binauloc = await rig.load("kemarcapture"), await rig.load("binauloc")
    await done(merged, "Homing")
    await done(binauloc, "connect_port", {"local": "KemarPort", "remote": "kemarcapture/Port"})
    await merged.send("StartCapture", {"device": source_scene(tmp_path, 120.0, seed=4, onset=0.0)})
    facing = await binauloc.send("FaceSource", {"velocity": 20.0})
    while not any(r.service.name == "MoveAbsolutePosition" for r in merged.requests.running()):
        await merged.currentState.wait_published()
    turn = next(r for r in merged.requests.running() if r.service.name == "MoveAbsolutePosition")
    # On its way to its first look (which way tells most, the planner says; either tells front from back).
    while abs(merged.currentState.read().position) < 2.0:
        await merged.currentState.wait_published()
    await done(binauloc, "Stop")
    await facing.ended.wait()
    assert facing.exception == {"ex": "::genom::interrupted", "detail": {"by": "Stop"}}
    assert turn.exception == {"ex": "::genom::interrupted", "detail": {"by": "abort"}}   # the head stopped
    with pytest.raises(NoSuchRequest):
        merged.requests.get(turn.number)                         # cleaned once ended: its id is free again
    stopped = await merged.azimuth_now()
    await rig.clock.sleep(2.0)
    assert 2.0 <= abs(stopped) < 30.0 and await merged.azimuth_now() == pytest.approx(stopped, abs=0.5)
