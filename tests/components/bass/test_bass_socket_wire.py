"""The 2015 socket's wire format, sans I/O: the MATLAB client's request lines and the 16-byte header."""

from __future__ import annotations

import numpy as np
import pytest

from aiogenomix.components.bass import (
    AudioSnapshot, ChunkHistory, FrameRead, FrameRequest, FrameRequestParser, encode_frame_reply, encode_frame_request,
    parse_frame_request,
)
from aiogenomix.components.bass._socket_wire import encode_snapshot_reply
from aiogenomix.components.audio import RequestError


def test_the_matlab_request_line() -> None:
    assert parse_frame_request(b"Read Port - N 4410 - nfr 0") == FrameRequest(4410, 0)
    assert encode_frame_request(4410, 0) == b"Read Port - N 4410 - nfr 0\n"
    assert parse_frame_request(b"Read Port - nfr 123456789012 - N 7") == FrameRequest(7, 123456789012)
    assert parse_frame_request(b"Close") is None


def test_lines_are_split_whatever_the_segments() -> None:
    parser = FrameRequestParser()
    assert parser.feed(b"Read Port - N 1") == []
    assert parser.feed(b"0 - nfr 5\r\nRead Port - N 2 - nfr 6\nClo") == [FrameRequest(10, 5), FrameRequest(2, 6)]
    assert parser.feed(b"se\n") == [None]


@pytest.mark.parametrize("line", [b"Read Port - Index 3", b"Read Port - N -4 - nfr 0", b"Read Port - nfr 0",
                                  b"hello", b"Read Port - N 99999999999 - nfr 0"])
def test_unreadable_requests_are_refused(line: bytes) -> None:
    with pytest.raises(RequestError):
        parse_frame_request(line)


def test_the_reply_is_header_then_left_block_then_right_block() -> None:
    left, right = np.array([1, 2, 3], np.int32), np.array([-1, -2, -3], np.int32)
    next_frame = 2**33 + 7                                  # needs the high half of the int64
    reply = encode_frame_reply(FrameRead(left, right, next_frame - 3, 5, next_frame - 1))
    assert len(reply) == 16 + 3 * 8
    words = np.frombuffer(bytes(reply), "<i4")
    assert words[:4].tolist() == [3, 5, 7, 2]                # n, lost, next (low, high)
    assert words[4:7].tolist() == [1, 2, 3] and words[7:].tolist() == [-1, -2, -3]


@pytest.mark.parametrize(("next_frame", "limit"), [(0, None), (9, None), (12, 5), (11, 3), (20, 8), (21, 4),
                                                   (3, 2), (10, 0), (13, None)])
def test_a_reply_copied_from_the_chunks_is_the_reply_of_the_read(next_frame: int, limit: int | None) -> None:
    history = ChunkHistory(3, 4, 16000)
    for i in range(1, 6):  # the port holds frames 9..20 in three chunks of four
        frames = np.arange((i - 1) * 4 + 1, i * 4 + 1)
        history.append(frames, -frames)
    snapshot = history.snapshot
    assert encode_snapshot_reply(snapshot, next_frame, limit) == encode_frame_reply(snapshot.frames(next_frame, limit))
    empty = AudioSnapshot.empty()
    assert encode_snapshot_reply(empty, next_frame, limit) == encode_frame_reply(empty.frames(next_frame, limit))
