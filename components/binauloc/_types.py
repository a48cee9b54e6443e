"""The IDL types and exceptions of ``binauloc``: the analysis window, the estimates it publishes, its refusals."""

from __future__ import annotations

import dataclasses
import enum
from typing import Annotated, TypeAlias

import numpy as np
from numpy.typing import NDArray

from ..core import Boolean, Double, GenomException, Grid, String, ULong, ULongLong, Unit, idl_enum, idl_struct

__all__ = ["Window", "AzimuthsData", "SourceData", "LogLikelihood", "e_setup", "e_noData", "e_rate", "e_noHead",
           "e_head"]

#: A log-likelihood for each azimuth 0°, 1°, …, 359° (a float64 numpy array of 360).
LogLikelihood: TypeAlias = NDArray[np.float64]


def _no_likelihood() -> np.ndarray:
    return np.zeros(0, dtype=np.float64)


@idl_enum("binauloc::window")
class Window(enum.Enum):
    """The analysis window of each frame (the Two!Ears scripts passed ``::localization::HANNING``)."""

    HANNING = 0
    HAMMING = 1
    BLACKMAN = 2
    RECTANGULAR = 3


@idl_struct("binauloc::azimuths")
class AzimuthsData:
    """One estimate of the dominant source's direction, as the Two!Ears decision layer read ``Azimuths``."""

    azimuth: Annotated[Double, Unit("rad"),
                       "Most likely azimuth, radians in the head frame (positive = left), (-pi, pi]"] = 0.0
    confidence: Annotated[Double, "Posterior probability within 10 degrees of it (0.5: a front/back tie)"] = 0.0
    frameIndex: Annotated[ULongLong, "The last frame it rests on, numbered as the connected port numbers them "
                                     "(bass: lastFrameIndex; capture: frames since the capture started)"] = 0
    nFrames: Annotated[ULong, "Analysis frames it rests on"] = 0
    headAzimuth: Annotated[Double, Unit("rad"),
                           "The head's azimuth in the room at frameIndex, radians (null: unknown)"] = 0.0
    roomAzimuth: Annotated[Double, Unit("rad"),
                           "azimuth + headAzimuth: the source in the room, radians (null: unknown)"] = 0.0
    estimate: Annotated[ULong, "Its number since LocalizeSources or FaceSource started (from 1)"] = 0
    logLikelihood: Annotated[LogLikelihood, Grid(0, 1, "deg"),
                             "Log-likelihood of each head-frame azimuth 0, 1, ..., 359 degrees"] = \
        dataclasses.field(default_factory=_no_likelihood)


@idl_struct("binauloc::source")
class SourceData:
    """The source FaceSource found: estimates at several head azimuths combined in the room."""

    roomAzimuth: Annotated[Double, Unit("rad"), "The source's azimuth in the room, radians (positive = left)"] = 0.0
    confidence: Annotated[Double, "Posterior probability within 10 degrees of it"] = 0.0
    headAzimuth: Annotated[Double, Unit("rad"), "Where the head is now, radians in the room"] = 0.0
    faced: Annotated[Boolean, "Whether the head faces the source (false when it lies beyond the head's limits)"] = \
        False
    turns: Annotated[ULong, "Head azimuths looked from besides the first"] = 0
    estimates: Annotated[ULong, "Estimates combined"] = 0
    logLikelihood: Annotated[LogLikelihood, Grid(0, 1, "deg"),
                             "Log-likelihood of each room azimuth 0, 1, ..., 359 degrees"] = \
        dataclasses.field(default_factory=_no_likelihood)


class e_setup(GenomException):
    """The analysis parameters make no analysis (``what`` says which and why)."""

    what: String


class e_noData(GenomException):
    """No audio to analyse: no audio in port is connected, or it stopped delivering."""

    what: String


class e_rate(GenomException):
    """The connected port's sample rate is not Setup's (``setup`` and ``port``, in Hz)."""

    setup: ULong
    port: ULong


class e_noHead(GenomException):
    """No component of this host turns a head (load kemar, kemarcapture or morse_kemar)."""

    what: String


class e_head(GenomException):
    """The head did not turn as asked (``what`` gives the head component's reason: not homed, a fault...)."""

    what: String
