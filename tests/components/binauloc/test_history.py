"""The estimate history: numbered estimates read by index, none lost to a slow reader while the window holds them."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from aiogenomix.components.binauloc import (
    MAX_SOURCES, EstimateHistory, EstimatesData, EstimateWindow, SourceAzimuthData,
)
from aiogenomix.components.core import Component, ComponentHost, HostSettings, OutPort, VirtualClock
from aiogenomix.components.recorder import Recorder
from aiogenomix.components.recording import RecordingReader


def sources(count: int, first: float = 0.1) -> tuple[SourceAzimuthData, ...]:
    return tuple(SourceAzimuthData(azimuth=first + k, roomAzimuth=math.nan, confidence=0.9, weight=0.2, power=0.3)
                 for k in range(count))


def test_estimates_after_an_index_are_read_once_each() -> None:
    history = EstimateHistory(capacity=8)
    assert history.window.index == 0 and history.window.since(0)[0].nEstimates == 0
    for number in range(1, 6):
        window = history.append(number * 5120, 10, None if number % 2 else 0.5, sources(number % 3 + 1))
    assert window.index == 5 and window.last == 5
    read, lost = window.since(2)
    assert lost == 0 and read.nEstimates == 3 and read.estimate.tolist() == [3, 4, 5] and read.last == 5
    assert read.frameIndex.tolist() == [15360, 20480, 25600] and read.nSources.tolist() == [1, 2, 3]
    # MAX_SOURCES slots per estimate, NaN after the sources it names.
    assert read.azimuth.shape == (3 * MAX_SOURCES,)
    assert read.azimuth[:MAX_SOURCES].tolist()[:1] == [0.1] and np.isnan(read.azimuth[1:MAX_SOURCES]).all()
    assert read.headAzimuth[1] == 0.5 and np.isnan(read.headAzimuth[0])
    assert window.since(5)[0].nEstimates == 0 and window.since(99)[1] == 0


def test_a_reader_slower_than_the_window_is_told_what_it_lost() -> None:
    history = EstimateHistory(capacity=4)
    for number in range(1, 11):
        window = history.append(number, 10, None, sources(1))
    read, lost = window.since(3)
    assert read.estimate.tolist() == [7, 8, 9, 10] and lost == 3     # estimates 4, 5 and 6 are gone
    assert window.data.estimate.tolist() == [7, 8, 9, 10]
    # A published window never changes: a reader holding it reads its estimates however many follow.
    history.append(11, 10, None, sources(1))
    assert window.since(0)[0].estimate.tolist() == [7, 8, 9, 10]


class Localiser(Component, name="localiser"):
    """Publishes estimates into a history by hand, as binauloc does."""

    Estimates: OutPort[EstimateWindow] = OutPort(EstimatesData, doc="The estimate history")


async def test_a_recording_holds_every_estimate_once(tmp_path: Path) -> None:
    settings = HostSettings(audio_socket_port=0, record_dirs=(str(tmp_path),))
    async with ComponentHost(clock=VirtualClock(), settings=settings,
                             factories={"localiser": Localiser, "recorder": Recorder}) as host:
        localiser = await host.load("localiser")
        history = EstimateHistory()
        localiser.Estimates.publish(history.append(100, 10, None, sources(1)))   # before the recording
        recorder = await host.load("recorder")
        recording = await recorder.send("Start", {"path": "estimates.mcap", "ports": ["localiser/Estimates"]})
        while not recorder.status().recording:
            await recorder.Status.wait_published()
        for number in range(2, 12):
            # Bursts of three publications between two reads of the recorder.
            localiser.Estimates.publish(history.append(100 * number, 10, None, sources(2)))
            if number % 3 == 0:
                await host.clock.sleep(0.1)
        await host.clock.sleep(0.1)
        await (await recorder.send("Stop")).ended.wait()
        await recording.ended.wait()
        assert recording.status == "done", recording.exception
    with open(tmp_path / "estimates.mcap", "rb") as stream, RecordingReader(stream) as reader:
        numbers = [n for message in reader.publications() for n in message.data["estimate"]]
    # The newest when it started, then each once.
    assert numbers == list(range(1, 12))
