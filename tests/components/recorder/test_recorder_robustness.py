"""The recorder goes on through what a rig does: data withdrawn for a while, a Stop that comes at once.

A port whose data its component withdrew (a camera whose render process restarts) is waited
for, not a reason to end the recording; the Status port counts those reads.  A Stop sent right
after Start, before the file is open, still ends the recording.  The rig runs on simulated time.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Callable
from pathlib import Path
from typing import Any

import pytest

from aiogenomix.components.core import (
    Component, ComponentHost, Double, GenomException, HostSettings, OutPort, String, VirtualClock,
)
from aiogenomix.components.recorder import Recorder, RecorderStatus
from aiogenomix.components.recording import RecordingReader


class DOWN(GenomException):
    """The probe's sensor is down."""

    what: String


class Probe(Component, name="probe"):
    """A sensor the test publishes and withdraws by hand."""

    Reading = OutPort(Double, doc="The sensor's reading")


@pytest.fixture
async def rig(tmp_path: Path) -> AsyncIterator[ComponentHost]:
    settings = HostSettings(audio_socket_port=0, record_dirs=(str(tmp_path),))
    async with ComponentHost(clock=VirtualClock(), settings=settings,
                             factories={"probe": Probe, "recorder": Recorder}) as host:
        yield host


async def status_until(recorder: Any, condition: Callable[[RecorderStatus], bool]) -> RecorderStatus:
    """The recorder's status once *condition* holds (its Status port publishes as the recording goes)."""
    while not condition(status := recorder.status()):
        await recorder.Status.wait_published()
    return status


def counts(status: RecorderStatus, port: str) -> dict[str, int]:
    return next(vars(p) for p in status.ports if p.port == port)


async def test_withdrawn_data_is_waited_for_and_counted(rig: ComponentHost, tmp_path: Path) -> None:
    probe = await rig.load("probe")
    probe.Reading.publish(1.0)
    probe.Reading.withdraw(DOWN(what="its process restarts"))
    recorder = await rig.load("recorder")
    # Started while the data is withdrawn: it records from the next publication on.
    recording = await recorder.send("Start", {"path": "probe.mcap", "ports": ["probe/Reading"]})
    await status_until(recorder, lambda s: s.recording and counts(s, "probe/Reading")["unavailable"] == 1)
    probe.Reading.publish(2.0)
    await status_until(recorder, lambda s: counts(s, "probe/Reading")["publications"] == 1)
    probe.Reading.publish(3.0)
    probe.Reading.withdraw(DOWN(what="its process restarts again"))  # before the recorder read it
    await status_until(recorder, lambda s: counts(s, "probe/Reading")["unavailable"] == 2)
    probe.Reading.publish(4.0)
    await status_until(recorder, lambda s: counts(s, "probe/Reading")["publications"] == 2)
    await (await recorder.send("Stop")).ended.wait()
    await recording.ended.wait()
    assert recording.status == "done", recording.exception
    assert recording.output["status"]["ended"] == "stopped" and recording.output["status"]["unavailable"] == 2
    with open(tmp_path / "probe.mcap", "rb") as stream, RecordingReader(stream) as reader:
        assert [m.data for m in reader.publications()] == [2.0, 4.0]
        assert reader.metadata()["aiogenomix.end"]["unavailable"] == "2"


async def test_a_stop_sent_right_after_start_ends_the_recording(rig: ComponentHost, tmp_path: Path) -> None:
    probe = await rig.load("probe")
    probe.Reading.publish(1.0)
    recorder = await rig.load("recorder")
    recording = await recorder.send("Start", {"path": "at_once.mcap", "ports": ["probe/Reading"]})
    stopping = await recorder.send("Stop")   # before Start has opened its file
    await asyncio.wait_for(asyncio.gather(stopping.ended.wait(), recording.ended.wait()), 30)
    assert stopping.status == "done" and recording.status == "done", recording.exception
    assert recording.output["status"]["ended"] == "stopped"
    with open(tmp_path / "at_once.mcap", "rb") as stream, RecordingReader(stream) as reader:
        assert reader.metadata()["aiogenomix.end"]["ended"] == "stopped"
    # A Stop with no recording running does nothing, and the next recording is not stopped by it.
    await (await recorder.send("Stop")).ended.wait()
    probe.Reading.publish(2.0)
    again = await recorder.send("Start", {"path": "later.mcap", "ports": ["probe/Reading"], "duration": 2})
    await again.ended.wait()
    assert again.status == "done" and again.output["status"]["ended"] == "duration"
