"""The estimate history of ``binauloc``: every estimate numbered, readable by index as ``bass`` numbers its frames.

``Azimuths`` holds the newest estimate only: a client that polls it more slowly
than estimates come, or over a busy network, misses some. The ``Estimates`` port
holds the last :data:`CAPACITY` estimates, numbered from 1 since the component
started, and is :class:`~aiogenomix.components.core.Incremental` by that number:
``/read/Estimates?since=K`` gives the estimates after K (and how many of them
the window no longer held), a ``watch`` gives each estimate once, and so does a
recording. Each publication is an :class:`EstimateWindow`, a frozen tuple of
rows, so a reader holding one reads exactly that publication's estimates.

The data is arrays (one element per estimate, :data:`~._types.MAX_SOURCES` per
estimate for the sources), as the audio ports' are: what another process
mirrors of numbered data, and what a recording splits into items, are arrays
with a fixed number of elements per item.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from ._types import MAX_SOURCES, EstimatesData, SourceAzimuthData

__all__ = ["EstimateRow", "EstimateWindow", "EstimateHistory", "CAPACITY"]

#: Estimates the port holds (at an estimate every 0.2 s, the last three minutes or so).
CAPACITY = 1024


@dataclasses.dataclass(frozen=True)
class EstimateRow:
    """One estimate as the history keeps it.

    Attributes:
        number: Its number (from 1 since the component started).
        frame_index: The last frame it rests on, numbered as the connected port numbers them.
        frames: Analysis frames it rests on.
        head_azimuth: The head's room azimuth at its last frame, radians (NaN: unknown).
        sources: Its sources, strongest first (at most :data:`MAX_SOURCES`).
    """

    number: int
    frame_index: int
    frames: int
    head_azimuth: float
    sources: tuple[SourceAzimuthData, ...]


@dataclasses.dataclass(frozen=True, eq=False)
class EstimateWindow:
    """One publication of the ``Estimates`` port: the rows it holds, oldest first, frozen."""

    rows: tuple[EstimateRow, ...] = ()

    @property
    def index(self) -> int:
        """The newest estimate's number (0 before the first): the incremental index of the port."""
        return self.rows[-1].number if self.rows else 0

    @property
    def items_per_publication(self) -> int:
        """Estimates a publication adds: a new ``watch`` starts with the newest."""
        return 1

    def since(self, index: int) -> tuple[EstimatesData, int]:
        """The estimates after estimate *index*, and how many of those the window no longer held."""
        oldest = self.rows[0].number if self.rows else self.index + 1
        rows = [row for row in self.rows if row.number > index]
        lost = max(0, min(oldest, self.index + 1) - (index + 1)) if index < self.index else 0
        return _data(self.index, rows), lost

    @functools.cached_property
    def data(self) -> EstimatesData:
        """Every estimate held, as the port struct."""
        return _data(self.index, list(self.rows))

    def __getattr__(self, name: str) -> object:
        # The struct's members (last, estimate, azimuth, ...) come from the whole window.
        if name.startswith("_") or name not in EstimatesData.__dataclass_fields__:
            raise AttributeError(name)
        return getattr(self.data, name)


def _data(last: int, rows: list[EstimateRow]) -> EstimatesData:
    count = len(rows)
    per_source = np.full((5, count, MAX_SOURCES), np.nan)
    for at, row in enumerate(rows):
        for slot, source in enumerate(row.sources[:MAX_SOURCES]):
            per_source[:, at, slot] = (source.azimuth, source.roomAzimuth, source.confidence, source.weight,
                                       source.power)
    azimuth, room, confidence, weight, power = (values.reshape(-1) for values in per_source)
    return EstimatesData(
        last=last, nEstimates=count,
        estimate=np.array([row.number for row in rows], dtype=np.uint64),
        frameIndex=np.array([row.frame_index for row in rows], dtype=np.uint64),
        nFrames=np.array([row.frames for row in rows], dtype=np.uint32),
        headAzimuth=np.array([row.head_azimuth for row in rows], dtype=np.float64),
        nSources=np.array([min(len(row.sources), MAX_SOURCES) for row in rows], dtype=np.uint32),
        azimuth=azimuth, roomAzimuth=room, confidence=confidence, weight=weight, power=power)


class EstimateHistory:
    """The last *capacity* estimates; each :meth:`append` returns the new window to publish.

    Args:
        capacity: Estimates held.
    """

    def __init__(self, capacity: int = CAPACITY) -> None:
        self.capacity = capacity
        self.window = EstimateWindow()
        self._next = 1

    def append(self, frame_index: int, frames: int, head_azimuth: float | None,
               sources: tuple[SourceAzimuthData, ...]) -> EstimateWindow:
        """Number the next estimate, keep it, and return the window that holds it."""
        head = math.nan if head_azimuth is None else float(head_azimuth)
        row = EstimateRow(self._next, frame_index, frames, head, sources)
        self._next += 1
        self.window = EstimateWindow((*self.window.rows[-(self.capacity - 1):], row) if self.capacity > 1 else (row,))
        return self.window
