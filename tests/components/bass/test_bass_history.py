"""The frame-indexed port, sans I/O: numbering as Ports.c, reads as getAudioData, snapshots that never change."""

from __future__ import annotations

import numpy as np
import pytest

from aiogenomix.components.bass import AudioSnapshot, ChunkHistory

FPC, CHUNKS = 4, 3


def chunk(i: int) -> tuple[np.ndarray, np.ndarray]:
    """Chunk *i* (from 1) holds its frames' indices on the left and their negatives on the right."""
    frames = np.arange((i - 1) * FPC + 1, i * FPC + 1)
    return frames, -frames


def history_after(chunks: int) -> ChunkHistory:
    history = ChunkHistory(CHUNKS, FPC, 16000)
    for i in range(1, chunks + 1):
        history.append(*chunk(i))
    return history


def test_a_fresh_port_is_zero_filled_at_frame_0() -> None:
    port = ChunkHistory(CHUNKS, FPC, 16000).snapshot
    assert (port.last_frame_index, port.oldest_frame_index) == (0, 0)
    data = port.data
    assert (data.sampleRate, data.nChunksOnPort, data.nFramesPerChunk, data.lastFrameIndex) == (16000, 3, 4, 0)
    assert data.left.tolist() == [0] * 12 and data.right.tolist() == [0] * 12


def test_last_frame_index_is_the_newest_frame_and_grows_by_a_chunk() -> None:
    port = history_after(2).snapshot
    assert port.last_frame_index == 8
    assert port.left[-1] == 8 and port.right[-1] == -8          # the newest frame is the last element
    assert port.left.tolist() == [0, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8]
    assert history_after(5).snapshot.left.tolist() == list(range(9, 21))


def test_reads_follow_get_audio_data() -> None:
    port = history_after(5).snapshot            # holds frames 9..20
    assert port.oldest_frame_index == 9
    read = port.frames(12, 5)
    assert (read.first, read.count, read.lost, read.next) == (12, 5, 0, 17)
    assert read.left.tolist() == [12, 13, 14, 15, 16] and read.right.tolist() == [-12, -13, -14, -15, -16]
    old = port.frames(0, 100)                    # older than the port: starts at its oldest, counts the skip
    assert (old.first, old.count, old.lost, old.next) == (9, 12, 9, 21)
    ahead = port.frames(25, 10)                  # beyond the newest: nothing, and the place is kept
    assert (ahead.count, ahead.lost, ahead.next) == (0, 0, 25)
    assert port.frames(21).count == 0


def test_since_reads_count_frames() -> None:
    port = history_after(5).snapshot
    newer, lost = port.since(18)
    assert newer.left.tolist() == [19, 20] and newer.lastFrameIndex == 20 and lost == 0
    newer, lost = port.since(2)
    assert newer.left.tolist() == list(range(9, 21)) and lost == 6


def test_a_published_snapshot_never_changes() -> None:
    history = history_after(3)
    held = history.snapshot
    before = held.frames(5, 8)
    for i in range(4, 40):                      # the window turns over many times
        history.append(*chunk(i))
    after = held.frames(5, 8)
    assert after.left.tolist() == before.left.tolist() == list(range(5, 13))
    assert held.data.left.tolist() == list(range(1, 13)) and held.last_frame_index == 12
    with pytest.raises(ValueError):
        held.chunks[-1][0, 0] = 99               # chunks are read-only


def test_the_empty_port_and_bad_chunks() -> None:
    empty = AudioSnapshot.empty()
    assert empty.frames(0, 10).count == 0 and empty.frames(0, 10).lost == 0
    assert empty.data.lastFrameIndex == 0 and empty.data.left.size == 0
    with pytest.raises(ValueError, match="4 frames per channel"):
        ChunkHistory(CHUNKS, FPC, 16000).append(np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError):
        history_after(1).snapshot.frames(-1)


def test_the_port_struct_of_another_process_reads_as_the_snapshot_it_came_from() -> None:
    for chunks in (0, 2, 5):
        published = history_after(chunks).snapshot
        rebuilt = AudioSnapshot.from_data(published.data)
        assert rebuilt.last_frame_index == published.last_frame_index
        for first in (0, 3, 9, 30):
            theirs, ours = published.frames(first, 5), rebuilt.frames(first, 5)
            assert (ours.first, ours.lost, ours.left.tolist(), ours.right.tolist()) == \
                   (theirs.first, theirs.lost, theirs.left.tolist(), theirs.right.tolist())
    assert AudioSnapshot.from_data(AudioSnapshot.empty().data).chunks == ()
    torn = history_after(2).snapshot.data
    torn.left = torn.left[1:]
    with pytest.raises(ValueError, match="cannot hold 11 and 12 frames"):
        AudioSnapshot.from_data(torn)
