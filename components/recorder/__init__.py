"""The ``recorder`` component: ports of the loaded instances kept in an MCAP file, next to the hardware."""

from ._component import Recorder
from ._types import (
    ALREADY_RECORDING, BAD_RECORDING, NO_SUCH_PORT, PATH_REFUSED, WRITE_FAILED, PortCounts, RecorderStatus,
)

__all__ = ["Recorder", "RecorderStatus", "PortCounts", "PATH_REFUSED", "NO_SUCH_PORT", "ALREADY_RECORDING",
           "BAD_RECORDING", "WRITE_FAILED"]
