"""The sans-I/O event-stream parser, fed whole and in every possible cut."""

from __future__ import annotations

import pytest
from aiogenomix.clients._sse import Comment, ServerSentEvent, SSEParser

STREAM = (
    b'event: request\ndata: {"id":"demo::0","status":"sent"}\n\n'
    b": ping\n\n"
    b'event: request\r\ndata: {"id":"demo::0","status":"done","output":{}}\r\n\r\n'
    b'event: unload\rdata: "demo"\r\r'
    b"event: quit\n\n"
)

EXPECTED = [
    ServerSentEvent("request", '{"id":"demo::0","status":"sent"}'),
    Comment("ping"),
    ServerSentEvent("request", '{"id":"demo::0","status":"done","output":{}}'),
    ServerSentEvent("unload", '"demo"'),
    ServerSentEvent("quit", ""),
]


def test_whole_stream() -> None:
    assert SSEParser().feed(STREAM) == EXPECTED


@pytest.mark.parametrize("cut", range(1, len(STREAM)))
def test_any_cut(cut: int) -> None:
    parser = SSEParser()
    assert parser.feed(STREAM[:cut]) + parser.feed(STREAM[cut:]) == EXPECTED


def test_byte_by_byte() -> None:
    parser = SSEParser()
    events = [e for i in range(len(STREAM)) for e in parser.feed(STREAM[i:i + 1])]
    assert events == EXPECTED


def test_fields() -> None:
    parser = SSEParser()
    events = parser.feed(b"data:a\ndata: b\nid: 7\nretry: 10\nfoo: bar\n\ndata\n\n\n\n")
    assert events == [ServerSentEvent("message", "a\nb", "7"), ServerSentEvent("message", "", "7")]
    assert parser.feed(b"event: x") == []               # incomplete: nothing yet
    assert parser.feed(b"\n\n") == [ServerSentEvent("x", "", "7")]


def test_utf8_split_inside_a_character() -> None:
    data = 'data: "vitesse réglée"\n\n'.encode()
    at = data.index("é".encode()) + 1
    parser = SSEParser()
    assert parser.feed(data[:at]) + parser.feed(data[at:]) == [ServerSentEvent("message", '"vitesse réglée"')]
