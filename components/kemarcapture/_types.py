"""The IDL types of the merged capture + KEMAR component (seed appendix 9.5.3, section 6.5)."""

from __future__ import annotations

import dataclasses

from typing import Annotated, TypeAlias

import numpy as np
from numpy.typing import NDArray

from ..capture import PORT_AUDIO, PortData
from ..core import Boolean, Double, ULong, Unit, idl_struct

__all__ = ["KemarPortData", "MoveIndexes", "Positions"]

#: Head positions in degrees, one per chunk, carried as a float64 numpy array.
Positions: TypeAlias = NDArray[np.float64]


def _no_positions() -> np.ndarray:
    return np.zeros(0, dtype=np.float64)


@idl_struct("kemarcapture::port_t", carries=dataclasses.replace(PORT_AUDIO, head_azimuth="positions"))
@dataclasses.dataclass
class KemarPortData(PortData):
    """The capture port plus the head position (degrees) at the end of each chunk, oldest first."""

    positions: Annotated[Positions, Unit("deg"), "Head azimuth at the end of each chunk, oldest first"] = \
        dataclasses.field(default_factory=_no_positions)


@idl_struct("kemarcapture::position_audio_indexes_movement")
class MoveIndexes:
    """Chunk index and head position when a MoveAbsolutePosition starts, and when it arrives.

    Published at the start (``arrived`` false, the end members zero) and again
    on arrival; an interrupted move publishes no arrival.
    """

    startIndex: ULong = 0
    startPosition: Annotated[Double, Unit("deg")] = 0.0
    endIndex: ULong = 0
    endPosition: Annotated[Double, Unit("deg")] = 0.0
    arrived: Boolean = False
