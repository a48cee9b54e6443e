"""A replay gives back every member its port recorded: kemarcapture replaying one publishes the recorded azimuths.

The head turns while ``kemarcapture/Port`` is recorded; then the live head is turned elsewhere and
the recording is played through ``kemarcapture`` (``mcap:PATH``).  Each replayed chunk must carry
the azimuth the head had when it was recorded, not the live head's (which it carried before: only
the chunks recorded where the live head stood matched).  The rig runs on a clock the drive and the
capture share (VirtualClock): the head and the chunks are where the test expects them.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import numpy as np
import pytest

from aiogenomix.components.core import ComponentHost, HostSettings, VirtualClock
from aiogenomix.components.kemarcapture import KemarCapture
from aiogenomix.components.recorder import Recorder
from aiogenomix.components.recording import RecordingReader

#: A rate whose 50 ms chunks halve into whole 25 ms ones.
RATE = 48000


@pytest.fixture
async def rig(tmp_path: Path) -> AsyncIterator[tuple[ComponentHost, KemarCapture, Recorder]]:
    settings = HostSettings(can="virtual", can_timeout=10.0, audio_socket_port=0, record_dirs=(str(tmp_path),),
                            audio_files=(str(tmp_path),))
    async with ComponentHost(clock=VirtualClock(), settings=settings,
                             factories={"kemarcapture": KemarCapture, "recorder": Recorder}) as host:
        head = await host.load("kemarcapture")
        recorder = await host.load("recorder")
        assert isinstance(head, KemarCapture) and isinstance(recorder, Recorder)
        homing = await head.send("Homing")
        await homing.ended.wait()
        assert homing.status == "done", homing.exception
        yield host, head, recorder


async def ended(component: KemarCapture | Recorder, service: str, inputs: dict[str, object]) -> dict[str, object]:
    request = await component.send(service, inputs)
    await request.ended.wait()
    assert request.status == "done", request.exception
    return dict(request.output or {})


async def record_a_turning_head(head: KemarCapture, recorder: Recorder, directory: Path) -> np.ndarray:
    """Record Port for three seconds while the head turns from 0 to 40 degrees; the recorded azimuths."""
    capturing = await head.send("StartCapture", {"device": "sim", "transfer_rate": RATE, "Port_chunks": 200})
    turning = await head.send("MoveAbsolutePosition", {"target": 40, "velocity": 20})
    await ended(recorder, "Start", {"path": "turn.mcap", "ports": ["kemarcapture/Port"], "duration": 3})
    await turning.ended.wait()
    await head.interrupt(capturing, by="test")
    with open(directory / "turn.mcap", "rb") as stream, RecordingReader(stream) as reader:
        return np.array([chunk.head_azimuth for chunk in reader.audio("kemarcapture/Port")])


async def replay(head: KemarCapture, chunk_time: int) -> np.ndarray:
    """The azimuths kemarcapture publishes while it plays the recording, a chunk of *chunk_time* ms at a time."""
    await ended(head, "StartCapture", {"device": "mcap:turn.mcap", "transfer_rate": RATE, "chunk_time": chunk_time,
                                      "Port_chunks": 400})
    port = head.Port.read()
    data, lost = port.since(0)
    assert lost == 0
    return np.asarray(data.positions)


@pytest.mark.parametrize("chunk_time", [50, 25])
async def test_kemarcapture_replaying_a_recording_publishes_the_recorded_azimuths(
        rig: tuple[ComponentHost, KemarCapture, Recorder], tmp_path: Path, chunk_time: int) -> None:
    _, head, recorder = rig
    recorded = await record_a_turning_head(head, recorder, tmp_path)
    assert len(recorded) >= 55 and recorded[0] < 1 and recorded[-1] > 39        # the head turned meanwhile
    await ended(head, "MoveAbsolutePosition", {"target": -20})                    # the live head is elsewhere
    replayed = await replay(head, chunk_time)
    if chunk_time == 50:  # the recorded chunks, one for one
        np.testing.assert_array_equal(replayed, recorded)
    else:                 # halves: each second one ends where a recorded chunk ended, the others half-way
        assert len(replayed) == 2 * len(recorded)
        np.testing.assert_array_equal(replayed[1::2], recorded)
        np.testing.assert_allclose(replayed[2::2], (recorded[:-1] + recorded[1:]) / 2)
    assert not np.any(replayed == -20)
