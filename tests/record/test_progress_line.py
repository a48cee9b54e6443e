"""The progress line of ``aiogenomix-record``: what is in the file, and what is still to come."""

from __future__ import annotations

import io

from aiogenomix.components.recording import RecordingCounts
from aiogenomix.record import ProgressLine


def counts(messages: int, queued: int, size: int) -> RecordingCounts:
    return RecordingCounts(bytes=size, messages=messages, queued=queued, lost_frames=0, coalesced=0, unavailable=0,
                           ports={})


def test_messages_not_yet_in_the_file_are_said_to_come() -> None:
    # Two seconds in: 83 messages recorded, the first chunk (61 of them, 10.2 kB) written, the rest gathering.
    line = ProgressLine.text(counts(83, 22, 10_200), 2.0)
    assert line == "    2.0 s  83 messages, 61 in the file (10.2 kB), 22 to come  0 frames lost  0 coalesced"


def test_a_file_that_has_no_chunk_yet_says_so() -> None:
    line = ProgressLine.text(counts(40, 40, 0), 0.5)
    assert "40 messages, 0 in the file (0 B), 40 to come" in line


def test_without_a_terminal_a_line_every_ten_seconds() -> None:
    stream = io.StringIO()
    progress = ProgressLine(stream)
    for elapsed in (0.0, 4.0, 9.9, 10.0, 15.0):
        progress(counts(10, 0, 5_000), elapsed)
    assert [line.split(" s ")[0].strip() for line in stream.getvalue().splitlines()] == ["0.0", "10.0"]
