"""The IDL types and exceptions of ``bass`` (``bassStruct.idl`` and ``bass.gen`` of the 2015 Two!Ears stack)."""

from __future__ import annotations

import dataclasses
from typing import Annotated, TypeAlias

import numpy as np
from numpy.typing import NDArray

from ..core import AudioStream, GenomException, String, ULong, ULongLong, Unit, idl_struct

__all__ = ["AudioPortData", "Samples", "DeviceList", "e_nomem", "e_nodevice", "e_device", "e_hwparams",
           "e_swparams", "e_socket"]

#: Samples of one channel, carried as an int32 numpy array.
Samples: TypeAlias = NDArray[np.int32]
DeviceList: TypeAlias = list[String]


def _no_samples() -> np.ndarray:
    return np.zeros(0, dtype=np.int32)


@idl_struct("binaudio::portStruct", carries=AudioStream(numbering="frames", index="lastFrameIndex", rate="sampleRate",
                                                      channels=("left", "right"), chunk_frames="nFramesPerChunk"))
class AudioPortData:
    """The newest frames of the capture, oldest first, indexed by frame.

    Frames are numbered from the start of the acquisition: the first captured
    frame is frame 1, and ``lastFrameIndex`` is the index of the newest frame,
    the last element of ``left`` and ``right``; it grows by ``nFramesPerChunk``
    with each chunk.  A full read holds ``nFramesPerChunk * nChunksOnPort``
    frames, zeros before the first ones (frame 0 and below).  An incremental read
    (``since=k``) holds frames ``k + 1 … lastFrameIndex`` that the port still has.
    """

    sampleRate: Annotated[ULong, Unit("Hz"), "Sample rate in Hz"] = 0
    nChunksOnPort: Annotated[ULong, "Chunks on the port"] = 0
    nFramesPerChunk: Annotated[ULong, "Frames in a chunk"] = 0
    lastFrameIndex: Annotated[ULongLong, "Index of the newest frame, the last of left and right (the first "
                                         "captured frame is frame 1)"] = 0
    left: Annotated[Samples, "Left samples (int32), oldest first"] = dataclasses.field(default_factory=_no_samples)
    right: Annotated[Samples, "Right samples (int32), as left"] = dataclasses.field(default_factory=_no_samples)


# The exceptions of bass.gen carry no data there; each carries a message here,
# so that a user reads why, not only what.

class e_nomem(GenomException):
    """The port cannot be allocated: nFramesPerChunk * nChunksOnPort frames is empty or too large."""

    what: String


class e_nodevice(GenomException):
    """No capture device can be found."""

    what: String


class e_device(GenomException):
    """The sound device cannot be opened, or failed while capturing (an overrun ends the acquisition)."""

    device: String
    what: String


class e_hwparams(GenomException):
    """The device refuses the hardware parameters (sample rate, format, channels, period)."""

    device: String
    what: String


class e_swparams(GenomException):
    """The device refuses the software parameters (start threshold, wake-up size)."""

    device: String
    what: String


class e_socket(GenomException):
    """The dedicated socket cannot be opened (port in use, already open); an aiogenomix addition to bass.gen."""

    port: ULong
    what: String
