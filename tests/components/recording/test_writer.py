"""The recording's writer thread wakes a recorder that waits for room, whenever it makes room.

The loop looks at the queue, finds it full and waits; the thread may make room at any moment,
including between that look and that wait.  The test holds the thread back and lets it go at
exactly that moment.
"""

from __future__ import annotations

import asyncio
import threading
import types
from pathlib import Path

import pytest

from aiogenomix.components.recording import RecordingWriter
from aiogenomix.components.recording import _writer


class WatchedCondition(threading.Condition):
    """The writer's condition, which says when the thread waits for work (it has done all it had)."""

    made: list[WatchedCondition] = []

    def __init__(self) -> None:
        super().__init__()
        self.idle = threading.Event()
        WatchedCondition.made.append(self)

    def wait(self, timeout: float | None = None) -> bool:
        self.idle.set()
        return super().wait(timeout)


async def test_room_made_between_the_look_and_the_wait_wakes_the_recorder(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    WatchedCondition.made.clear()
    monkeypatch.setattr(_writer, "threading", types.SimpleNamespace(Condition=WatchedCondition,
                                                                    Thread=threading.Thread))
    writer = RecordingWriter(open(tmp_path / "w.mcap", "xb", buffering=0), queue_bytes=100)
    ready = WatchedCondition.made[0]
    try:
        channel = writer.channel("/probe", "json", 0)
        await asyncio.to_thread(ready.idle.wait, 10)   # the thread has made the file and waits for work
        ready.acquire()                                # it cannot take the next message while this is held
        writer.message(channel, 1, 1, 1, b"x" * 200)   # more than the queue takes: no room until it is written
        ready.idle.clear()
        looked = writer.has_room

        def has_room_then_let_go() -> bool:
            writer.has_room = looked  # type: ignore[method-assign]  # (once)
            full = looked()
            ready.release()                            # the thread writes the message now...
            assert ready.idle.wait(10)                 # ...and is done with it: it made room, and looked
            return full

        writer.has_room = has_room_then_let_go  # type: ignore[method-assign]
        assert not looked()
        await asyncio.wait_for(writer.wait_room(), 10)
        assert looked()
    finally:
        await writer.close()
