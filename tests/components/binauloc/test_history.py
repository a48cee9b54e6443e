"""The estimate history: numbered estimates read by index, none lost to a slow reader while the window holds them."""

from __future__ import annotations

import math

import numpy as np

from aiogenomix.components.binauloc import MAX_SOURCES, EstimateHistory, SourceAzimuthData


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
