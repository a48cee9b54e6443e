"""Issue 26, acceptance 3: a recording played again as a capture device (``mcap:PATH``).

``bass`` acquiring from a recording publishes the recorded samples bit for bit; a gap in the
recording stays a gap (its chunks are not delivered, the next one says what was lost and
comes at its time); another sample rate is refused, and so is a file outside the allowed
directories.  Simulated time throughout.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import AsyncIterator
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from aiogenomix.components.audio import FormatRefused, open_backend
from aiogenomix.components.bass import AudioPortData, Bass
from aiogenomix.components.core import ComponentHost, HostSettings, ManualClock, VirtualClock
from aiogenomix.components.core.runtime import idl_type
from aiogenomix.components.recorder import Recorder
from aiogenomix.components.recording import AudioRecorder, Recording, create_recording

RATE, FPC = 44100, 2205
#: bass's port as /info describes it (what it carries: audio numbered by frame).
BASS_AUDIO = idl_type(AudioPortData).describe()


@pytest.fixture
async def host(tmp_path: Path) -> AsyncIterator[ComponentHost]:
    settings = HostSettings(audio_socket_port=0, audio_files=(), record_dirs=(str(tmp_path),))
    async with ComponentHost(clock=VirtualClock(), settings=settings,
                             factories={"bass": Bass, "recorder": Recorder}) as running:
        yield running


def recorded_frames(path: Path, topic: str) -> np.ndarray:
    with open(path, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        return np.concatenate([np.frombuffer(bytes(m.audio.data), "<i4").reshape(-1, 2)
                               for _, _, _, m in reader.iter_decoded_messages(topics=[topic])])


async def acquire_all(bass: Bass, device: str, **inputs: int) -> tuple[np.ndarray, str]:
    """Acquire from *device* until its end, reading every frame the port publishes; return them and the end."""
    version = bass.Audio.version
    request = await bass.send("Acquire", {"device": device, **inputs})
    await bass.Audio.wait_published(version)  # the new acquisition's port, zero-filled from frame 0
    frames, next_frame = [], 1
    while request.running or bass.snapshot.last_frame_index >= next_frame:
        snapshot = bass.snapshot
        if snapshot.last_frame_index >= next_frame:
            read = snapshot.frames(next_frame)
            assert read.lost == 0
            frames.append(np.stack([read.left, read.right], axis=1))
            next_frame = read.next
            continue
        # The next publication, or the end of the acquisition (after its last publication).
        ended = asyncio.ensure_future(request.ended.wait())
        await asyncio.wait([ended, bass.Audio.next_publication()], return_when=asyncio.FIRST_COMPLETED)
        ended.cancel()
    return np.concatenate(frames), request.status


async def test_bass_acquiring_a_recording_publishes_the_recorded_samples_bit_for_bit(host: ComponentHost,
                                                                                     tmp_path: Path) -> None:
    bass = await host.load("bass")
    assert isinstance(bass, Bass)
    live = await bass.send("Acquire", {"device": "sim"})
    recorder = await host.load("recorder")
    recording = await recorder.send("Start", {"path": "bass.mcap", "ports": ["bass/Audio"], "duration": 3})
    await recording.ended.wait()
    assert recording.status == "done", recording.exception
    await bass.interrupt(live, by="test")
    original = recorded_frames(tmp_path / "bass.mcap", "/bass/Audio")
    assert len(original) >= 55 * FPC

    replayed, ended = await acquire_all(bass, "mcap:bass.mcap")
    assert ended == "done"                                  # the recording's end ends the acquisition
    np.testing.assert_array_equal(replayed, original)

    # Another chunk size: the same frames, the last chunk completed with zeros.
    replayed, _ = await acquire_all(bass, f"mcap:{tmp_path / 'bass.mcap'}", nFramesPerChunk=1000)
    np.testing.assert_array_equal(replayed[:len(original)], original)
    assert not replayed[len(original):].any() and len(replayed) - len(original) < 1000


async def test_another_rate_and_a_file_outside_the_directories_are_refused(host: ComponentHost,
                                                                           tmp_path: Path) -> None:
    bass = await host.load("bass")
    live = await bass.send("Acquire", {"device": "sim"})
    recorder = await host.load("recorder")
    recording = await recorder.send("Start", {"path": "rate.mcap", "ports": ["bass/Audio"], "duration": 0.5})
    await recording.ended.wait()
    await bass.interrupt(live, by="test")
    refused = await bass.send("Acquire", {"device": "mcap:rate.mcap", "sampleRate": 48000})
    await refused.ended.wait()
    assert refused.exception["ex"] == "::bass::e_hwparams"
    assert refused.exception["detail"]["what"] == ("'rate.mcap' was recorded at 44100 Hz, the capture asks for "
                                                   "48000 Hz (no resampling)")
    outside = tmp_path.parent / "elsewhere.mcap"
    refused = await bass.send("Acquire", {"device": f"mcap:{outside}"})
    await refused.ended.wait()
    assert refused.exception["ex"] == "::bass::e_device"
    assert "not in a directory this host allows for recordings (--audio-files, --record-dir)" in \
        refused.exception["detail"]["what"]


async def test_a_gap_in_the_recording_stays_a_gap(tmp_path: Path) -> None:
    """A recording that missed three chunks: the replay delivers nothing for them, then says so, on time."""
    stream, path, *_ = create_recording(str(tmp_path / "gap.mcap"), None)
    recording = Recording.open(stream, path, {})
    audio = recording.add_port("bass/Audio", {"name": "Audio", "doc": "", "type": BASS_AUDIO})
    rng = np.random.default_rng(3)
    chunks = [rng.integers(-2**31, 2**31, (FPC, 2), dtype=np.int32) for _ in range(8)]
    now = time.time()

    def port(last_chunk: int, count: int) -> dict[str, object]:
        both = np.concatenate(chunks[last_chunk - count:last_chunk])
        return {"sampleRate": RATE, "nChunksOnPort": 20, "nFramesPerChunk": FPC, "lastFrameIndex": last_chunk * FPC,
                "left": both[:, 0], "right": both[:, 1]}

    audio.write(port(2, 2), lost=0, rig_time=now)           # chunks 1 and 2
    audio.write(port(8, 3), lost=3 * FPC, rig_time=now)     # 3, 4, 5 missed; 6, 7, 8 kept
    await recording.close("test")

    clock = ManualClock()
    backend = open_backend(f"mcap:{path}", RATE, FPC, clock, roots=None)
    delivered = []
    async with backend:
        while (chunk := await clock.run_until(backend.read())) is not None:
            delivered.append((chunk, clock.now()))
    assert len(delivered) == 5
    for (chunk, _), expected in zip(delivered, [chunks[0], chunks[1], *chunks[5:]], strict=True):
        np.testing.assert_array_equal(chunk.frames, expected)
    assert [c.lost_frames for c, _ in delivered] == [0, 0, 3 * FPC, 0, 0]
    assert [c.overrun for c, _ in delivered] == [False, False, True, False, False]
    # Each chunk comes when its last frame would have been captured: the gap lasts its 150 ms.
    assert [round(t, 6) for _, t in delivered] == [0.05, 0.1, 0.3, 0.35, 0.4]
    starts = np.array([c.time for c, _ in delivered]) - delivered[0][0].time
    np.testing.assert_allclose(starts, [0, 0.05, 0.25, 0.3, 0.35], atol=1e-6)  # POSIX seconds in a double: microseconds


async def bass_recording(path: Path, captures: list[tuple[int, int, float]], seed: int = 4) -> list[np.ndarray]:
    """A recording of bass's port over captures ``(chunks, rate, rig time of the last read)``; their chunks."""
    stream, real, *_ = create_recording(str(path), None)
    recording = Recording.open(stream, real, {})
    audio = recording.add_port("bass/Audio", {"name": "Audio", "doc": "", "type": BASS_AUDIO})
    assert isinstance(audio, AudioRecorder)
    rng = np.random.default_rng(seed)
    made = []
    for count, rate, read_at in captures:
        chunks = [rng.integers(-2**31, 2**31, (FPC, 2), dtype=np.int32) for _ in range(count)]
        both = np.concatenate(chunks)
        audio.restarted(count * FPC)  # a new capture numbers its frames from 1 again
        audio.write({"sampleRate": rate, "nChunksOnPort": 20, "nFramesPerChunk": FPC, "lastFrameIndex": count * FPC,
                     "left": both[:, 0], "right": both[:, 1]}, lost=0, rig_time=read_at)
        made += chunks
    await recording.close("test")
    return made


async def test_a_capture_that_started_again_is_played_after_the_first_with_the_pause_between(tmp_path: Path) -> None:
    now = time.time()
    # Three chunks read at `now`, then a new capture whose two chunks were read 0.3 s later: 0.2 s of pause.
    made = await bass_recording(tmp_path / "restart.mcap", [(3, RATE, now), (2, RATE, now + 0.3)])
    clock = ManualClock()
    backend = open_backend(f"mcap:{tmp_path / 'restart.mcap'}", RATE, FPC, clock, roots=None)
    delivered = []
    async with backend:
        while (chunk := await clock.run_until(backend.read())) is not None:
            delivered.append((chunk, clock.now()))
    assert len(delivered) == 5
    for (chunk, _), expected in zip(delivered, made, strict=True):
        np.testing.assert_array_equal(chunk.frames, expected)
    assert [c.lost_frames for c, _ in delivered] == [0, 0, 0, 4 * FPC, 0]  # the pause: four chunks' time
    assert [round(t, 6) for _, t in delivered] == [0.05, 0.1, 0.15, 0.4, 0.45]


async def test_a_capture_that_started_again_at_another_rate_ends_the_replay_saying_so(tmp_path: Path) -> None:
    now = time.time()
    await bass_recording(tmp_path / "rates.mcap", [(3, RATE, now), (2, 48000, now + 1.0)])
    clock = ManualClock()
    backend = open_backend(f"mcap:{tmp_path / 'rates.mcap'}", RATE, FPC, clock, roots=None)
    async with backend:
        for _ in range(3):
            assert await clock.run_until(backend.read()) is not None
        with pytest.raises(FormatRefused, match="from frame 1 of its next capture at 48000 Hz"):
            await clock.run_until(backend.read())
