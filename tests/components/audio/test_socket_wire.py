"""The dedicated-socket wire format without sockets: requests, replies, Table 6.3 byte counts."""

from __future__ import annotations

import numpy as np
import pytest

from aiogenomix.components.audio import (
    ChunkWindow, RequestError, RequestParser, encode_error, encode_reply, encode_request, parse_request, reply_size,
)
from aiogenomix.components.audio._socket_wire import encode_state_reply

FPC = 2205  # 50 ms at 44.1 kHz


@pytest.mark.parametrize(("chunks", "size"), [(10, 176448), (20, 352888), (80, 1411528)])
def test_table_6_3_byte_counts(chunks: int, size: int) -> None:
    window = ChunkWindow(chunks, FPC, with_positions=True)
    for i in range(chunks):
        window.append(np.full(FPC, i), np.full(FPC, -i), position=float(i))
    reply = encode_reply(window.since(0), with_positions=True)
    assert len(reply) == size == reply_size(chunks, FPC, with_positions=True)
    # Table 6.3's sample count: chunks * (2 * 2205 + 1) + 2 four-byte values.
    assert len(reply) // 4 == chunks * (2 * FPC + 1) + 2


@pytest.mark.parametrize("positions", [True, False])
@pytest.mark.parametrize("index", [0, 1, 3, 5, 6, 7, 100])
def test_a_reply_made_from_the_chunks_is_the_reply_of_the_window_read(positions: bool, index: int) -> None:
    window = ChunkWindow(4, 5, with_positions=positions)
    for i in range(1, 7):
        window.append(np.arange(5) + 10 * i, -np.arange(5) - 10 * i, position=i * 1.5 if positions else None)
    expected = encode_reply(window.since(index), with_positions=positions)
    assert encode_state_reply(window.state, index, with_positions=positions) == expected
    if not positions:
        with pytest.raises(ValueError, match="positions"):
            encode_state_reply(window.state, index, with_positions=True)


def test_reply_layout() -> None:
    window = ChunkWindow(4, 3, with_positions=True)
    for i in range(1, 7):
        window.append([i, i, i], [-i, -i, -i], position=i * 1.5)
    reply = encode_reply(window.since(3), with_positions=True)
    ints = np.frombuffer(reply[:4 * (2 + 2 * 9)], dtype="<i4")
    assert ints[0] == 3
    assert ints[1:10].tolist() == [4, 4, 4, 5, 5, 5, 6, 6, 6]
    assert ints[10:19].tolist() == [-4, -4, -4, -5, -5, -5, -6, -6, -6]
    assert ints[19] == 6
    assert np.frombuffer(reply[4 * 20:], dtype="<f4").tolist() == [6.0, 7.5, 9.0]


def test_reply_without_positions_is_the_capture_format() -> None:
    window = ChunkWindow(2, 3)
    window.append([1, 2, 3], [4, 5, 6])
    ints = np.frombuffer(encode_reply(window.since(0)), dtype="<i4")
    assert ints.tolist() == [1, 1, 2, 3, 4, 5, 6, 1]


def test_count_is_clamped_never_negative() -> None:
    window = ChunkWindow(20, 3)
    for _ in range(50):
        window.append([0, 0, 0], [0, 0, 0])
    assert np.frombuffer(encode_reply(window.since(0)), "<i4")[0] == 20
    assert np.frombuffer(encode_reply(window.since(49)), "<i4")[0] == 1
    nothing = np.frombuffer(encode_reply(window.since(1000)), "<i4")
    assert nothing.tolist() == [0, 50]


def test_positions_are_needed_for_the_merged_format() -> None:
    window = ChunkWindow(2, 3)
    window.append([0, 0, 0], [0, 0, 0])
    with pytest.raises(ValueError, match="positions"):
        encode_reply(window.since(0), with_positions=True)


@pytest.mark.parametrize(("line", "index"), [
    (b"Read Port - Index 0", 0), (b"Read Port - Index 12345", 12345), (b"read port - index 7 ", 7),
    (b"Read Port-Index 3", 3),
])
def test_parse_request(line: bytes, index: int) -> None:
    assert parse_request(line) == index


@pytest.mark.parametrize("line", [b"", b"Read Port", b"Read Port - Index -3", b"Read Port - Index 2.5",
                                  b"Read Port - Index x", b"GET / HTTP/1.1", b"\xff\xfe"])
def test_bad_requests_are_refused(line: bytes) -> None:
    with pytest.raises(RequestError, match="Read Port - Index"):
        parse_request(line)


def test_parser_joins_partial_lines_and_accepts_crlf() -> None:
    parser = RequestParser()
    assert parser.feed(b"Read Port - In") == []
    assert parser.feed(b"dex 4\r\nRead Port - Index 5\nRead") == [4, 5]
    assert parser.feed(b" Port - Index 6\n") == [6]


def test_parser_refuses_endless_lines() -> None:
    with pytest.raises(RequestError, match="longer than"):
        RequestParser().feed(b"x" * 600)


def test_request_and_error_lines() -> None:
    assert encode_request(42) == b"Read Port - Index 42\n"
    assert parse_request(encode_request(42).rstrip(b"\n")) == 42
    with pytest.raises(ValueError):
        encode_request(-1)
    assert encode_error("bad\nthing") == b"ERROR bad thing\n"
