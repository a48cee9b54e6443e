"""An audio port recorder keeps every frame once whatever a read holds: what it had already is skipped, never repeated.

A read that holds more than was asked (a reader that resumed from too far back) must not
duplicate or misnumber frames, and a capture's read that is not whole chunks is refused
rather than cut at the wrong places.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aiogenomix.components.recording import AudioRecorder, Recording, RecordingError, RecordingReader

RATE = 1000
PER_CHUNK = 50
SAMPLES = {"kind": "sequence", "name": "sequence<long>", "bound": None, "element": {"name": "long", "kind": "long"}}
INTEGER = {"name": "unsigned long", "kind": "unsigned long"}
TIME = {"name": "::t", "kind": "struct", "members": [{"name": "tv_sec", "type": {"name": "long", "kind": "long"}},
                                                       {"name": "tv_nsec", "type": {"name": "long", "kind": "long"}}]}
# Audio ports as /info describes them: what the port carries says how it is numbered and where its samples are.
BASS = {"name": "b/Audio", "dir": "out", "type": {
    "name": "::b::frames", "kind": "struct",
    "members": [{"name": n, "type": t} for n, t in (("sampleRate", INTEGER), ("nFramesPerChunk", INTEGER),
                                                    ("lastFrameIndex", INTEGER), ("left", SAMPLES),
                                                    ("right", SAMPLES))],
    "carries": {"kind": "audio", "numbering": "frames", "index": "lastFrameIndex", "rate": "sampleRate",
                "channels": ["left", "right"], "chunk_frames": "nFramesPerChunk"}}}
CAPTURE = {"name": "c/Port", "dir": "out", "type": {
    "name": "::c::chunks", "kind": "struct",
    "members": [{"name": n, "type": t} for n, t in (("transfer_rate", INTEGER), ("index", INTEGER), ("ts", TIME),
                                                    ("left", SAMPLES), ("right", SAMPLES))],
    "carries": {"kind": "audio", "numbering": "chunks", "index": "index", "rate": "transfer_rate",
                "channels": ["left", "right"], "start": "ts"}}}


def frames(first: int, last: int) -> np.ndarray:
    """Samples that say their own frame number (left) and its negative (right)."""
    return np.arange(first, last + 1, dtype=np.int32)


def bass_read(first: int, last: int) -> dict[str, Any]:
    samples = frames(first, last)
    return {"sampleRate": RATE, "nFramesPerChunk": PER_CHUNK, "lastFrameIndex": last, "left": samples,
            "right": -samples}


def capture_read(first_chunk: int, last_chunk: int) -> dict[str, Any]:
    samples = frames((first_chunk - 1) * PER_CHUNK + 1, last_chunk * PER_CHUNK)
    return {"transfer_rate": RATE, "index": last_chunk, "ts": {"tv_sec": 1000, "tv_nsec": 0}, "left": samples,
            "right": -samples}


async def recorded(path: Path, description: dict[str, Any], reads: list[tuple[dict[str, Any], int, int]]
                   ) -> tuple[list[int], np.ndarray, int]:
    """Record *reads* ``(data, since asked, lost)``; return the first frames, the samples and the lost frames."""
    stream = open(path, "xb", buffering=0)  # noqa: SIM115 -- the recording's writer closes it
    recording = Recording.open(stream, str(path), {})
    recorder = recording.add_port(description["name"], description)
    assert isinstance(recorder, AudioRecorder)
    recorder.start_at(reads[0][1])
    try:
        for data, _, lost in reads:  # each read holds what it holds: the recorder reads its items from the data
            recorder.write(data, lost=lost, rig_time=2000.0)
    finally:
        await recording.close("stopped")
    with open(path, "rb") as file, RecordingReader(file) as reader:
        chunks = list(reader.audio())
    return [c.first_frame for c in chunks], np.concatenate([c.frames for c in chunks]), recorder.lost_frames


async def test_frames_a_read_repeats_are_recorded_once(tmp_path: Path) -> None:
    # The second read asked after frame 300 but holds 101…500, as a watch resumed from its first since=.
    firsts, samples, lost = await recorded(tmp_path / "b.mcap", BASS, [(bass_read(101, 300), 100, 0),
                                                                       (bass_read(101, 500), 300, 0)])
    np.testing.assert_array_equal(samples[:, 0], frames(101, 500))
    np.testing.assert_array_equal(samples[:, 1], -frames(101, 500))
    assert firsts == [101, 151, 201, 251, 301, 351, 401, 451] and lost == 0


async def test_frames_a_read_misses_are_counted_as_lost(tmp_path: Path) -> None:
    firsts, samples, lost = await recorded(tmp_path / "b.mcap", BASS, [(bass_read(101, 200), 100, 0),
                                                                       (bass_read(251, 300), 200, 50)])
    assert firsts == [101, 151, 251] and lost == 50
    np.testing.assert_array_equal(samples[:, 0], np.concatenate([frames(101, 200), frames(251, 300)]))


async def test_chunks_a_read_repeats_are_recorded_once(tmp_path: Path) -> None:
    # Chunks 3…4, then a read asked after chunk 4 that holds 3…7.
    firsts, samples, lost = await recorded(tmp_path / "c.mcap", CAPTURE, [(capture_read(3, 4), 2, 0),
                                                                          (capture_read(3, 7), 4, 0)])
    np.testing.assert_array_equal(samples[:, 0], frames(101, 350))
    assert firsts == [101, 151, 201, 251, 301] and lost == 0


async def test_a_capture_read_that_is_not_whole_chunks_is_refused(tmp_path: Path) -> None:
    read = capture_read(3, 4)
    read["left"], read["right"] = read["left"][:-1], read["right"][:-1]
    with pytest.raises(RecordingError, match="holds 99 frames, not 2 whole chunks"):
        await recorded(tmp_path / "c.mcap", CAPTURE, [(read, 2, 0)])
