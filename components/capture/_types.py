"""The IDL types and declared exceptions of the capture component (seed appendix 9.5.1)."""

from __future__ import annotations

import dataclasses
from typing import Annotated, TypeAlias

import numpy as np
from numpy.typing import NDArray

from .. import core
from ..core import AudioStream, Boolean, GenomException, String, ULong, ULongLong, Unit, idl_struct

__all__ = [
    "Timestamp", "PortData", "PORT_AUDIO", "CaptureConfig", "CaptureStatus", "Samples", "DeviceList",
    "INVALID_CHUNK_TIME", "ERROR_SEQUENCE_ENOMEM", "NO_SUCH_DEVICE", "DEVICE_ERROR", "ALREADY_CAPTURING",
    "SOCKET_ERROR",
]

#: Samples of one channel, carried as an int32 numpy array.
Samples: TypeAlias = NDArray[np.int32]
DeviceList: TypeAlias = list[String]


def _no_samples() -> np.ndarray:
    return np.zeros(0, dtype=np.int32)


@idl_struct("capture::timestamp_t")
class Timestamp(core.Timestamp):
    """A POSIX time split into seconds and nanoseconds."""


#: What Port carries: chunks numbered by ``index``, timed from ``ts``.
PORT_AUDIO = AudioStream(numbering="chunks", index="index", rate="transfer_rate", channels=("left", "right"),
                         start="ts")


@idl_struct("capture::port_t", carries=PORT_AUDIO)
class PortData:
    """The newest chunks of the capture, oldest first (the linear port of the seed, section 5.2.1).

    ``index`` counts the chunks published since the capture started, so the
    newest chunk has index ``index`` and the port holds chunks
    ``index - Port_chunks + 1 … index`` (zeros before the first ones).  Frame
    ``j`` of chunk ``i`` was captured at ``ts + ((i - 1) * chunk frames + j) / transfer_rate``.
    """

    transfer_rate: Annotated[ULong, Unit("Hz"), "Sample rate in Hz"] = 0
    nbframes: Annotated[ULong, "Frames in left (and in right): Port_chunks chunks of frames"] = 0
    index: Annotated[ULong, "Chunks captured so far: the index of the newest chunk (the last one of left)"] = 0
    ts: Annotated[Timestamp, "When the capture started (it does not change while it runs): frame j of chunk i "
                             "was captured at ts + ((i - 1) * chunk frames + j) / transfer_rate"] = \
        dataclasses.field(default_factory=Timestamp)
    left: Annotated[Samples, "Left samples (int32), oldest first; zeros before the first chunk"] = \
        dataclasses.field(default_factory=_no_samples)
    right: Annotated[Samples, "Right samples (int32), as left"] = dataclasses.field(default_factory=_no_samples)


@dataclasses.dataclass
class CaptureConfig:
    """The outputs of GetCaptureConfig: the parameters of the current (or last) capture."""

    device: Annotated[String, "Name of the sound device"] = ""
    transfer_rate: Annotated[ULong, Unit("Hz"), "Sample rate in Hz"] = 0
    chunk_time: Annotated[ULong, Unit("ms"), "Size of transfer chunks in milliseconds"] = 0
    Port_chunks: Annotated[ULong, "Size of the Port in number of chunks"] = 0


@dataclasses.dataclass
class CaptureStatus:
    """The outputs of GetCaptureStatus."""

    capturing: Annotated[Boolean, "Whether a capture is running"] = False
    device: Annotated[String, "The device of the current (or last) capture"] = ""
    index: Annotated[ULongLong, "Chunks published since the capture started"] = 0
    overruns: Annotated[ULong, "Times the device or the hand-over lost frames"] = 0
    lost_frames: Annotated[ULongLong, "Frames lost in those overruns"] = 0
    socket_port: Annotated[ULong, "TCP port of the dedicated socket (0: closed)"] = 0
    socket_clients: Annotated[ULong, "Clients connected to the dedicated socket"] = 0


class INVALID_CHUNK_TIME(GenomException):
    """transfer_rate * chunk_time / 1000 is not a whole number of frames, or is out of range."""

    what: String


class ERROR_SEQUENCE_ENOMEM(GenomException):
    """The port (Port_chunks chunks of both channels) cannot be allocated: too large, or empty."""

    what: String


class NO_SUCH_DEVICE(GenomException):
    """The sound device does not exist; ``available`` lists the devices that do."""

    device: String
    available: DeviceList


class DEVICE_ERROR(GenomException):
    """The sound device (or its library) failed while opening or capturing."""

    device: String
    what: String


class ALREADY_CAPTURING(GenomException):
    """A capture is running: StopCapture it before starting another."""

    device: String


class SOCKET_ERROR(GenomException):
    """The dedicated socket cannot be opened (port in use, already open, ...)."""

    port: ULong
    what: String
