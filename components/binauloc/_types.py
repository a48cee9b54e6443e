"""The IDL types and exceptions of ``binauloc``: the analysis window, the estimates it publishes, its refusals."""

from __future__ import annotations

import dataclasses
import enum
from typing import Annotated, TypeAlias

import numpy as np
from numpy.typing import NDArray

from ..core import Boolean, Double, GenomException, Grid, String, ULong, ULongLong, Unit, idl_enum, idl_struct

__all__ = ["Window", "Target", "AzimuthsData", "SourceAzimuthData", "SourceData", "EstimatesData", "LogLikelihood",
           "MAX_SOURCES", "e_setup", "e_noData", "e_rate", "e_noHead", "e_head"]

#: The most sources an estimate names (LocalizeSources' nSources, the history's slots per estimate).
MAX_SOURCES = 6

#: A log-likelihood for each azimuth 0°, 1°, …, 359° (a float64 numpy array of 360).
LogLikelihood: TypeAlias = NDArray[np.float64]


def _no_likelihood() -> np.ndarray:
    return np.zeros(0, dtype=np.float64)


def _no_numbers() -> np.ndarray:
    return np.zeros(0, dtype=np.uint64)


def _no_counts() -> np.ndarray:
    return np.zeros(0, dtype=np.uint32)


@idl_enum("binauloc::window")
class Window(enum.Enum):
    """The analysis window of each frame (the Two!Ears scripts passed ``::localization::HANNING``)."""

    HANNING = 0
    HAMMING = 1
    BLACKMAN = 2
    RECTANGULAR = 3


@idl_enum("binauloc::target")
class Target(enum.Enum):
    """Which of several sources FaceSource faces."""

    LOUDEST = 0
    NEAREST = 1


@idl_struct("binauloc::source_azimuth")
class SourceAzimuthData:
    """One source of an estimate."""

    azimuth: Annotated[Double, Unit("rad"), "Radians in the head frame (positive = left), (-pi, pi]"] = 0.0
    roomAzimuth: Annotated[Double, Unit("rad"), "Radians in the room (null: the head's azimuth is unknown)"] = 0.0
    confidence: Annotated[Double, "The share of its region's probability within 10 degrees of it (0.5: a "
                                  "front/back tie)"] = 0.0
    weight: Annotated[Double, "Its share of the glimpses (the sources' and the background's make 1)"] = 0.0
    power: Annotated[Double, "Its share of the glimpses' power (the loudest has the most)"] = 0.0


@idl_struct("binauloc::azimuths")
class AzimuthsData:
    """One estimate, as the Two!Ears decision layer read ``Azimuths``: the strongest source first, then all."""

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
                             "Log of the sources' distribution over head-frame azimuths 0, 1, ..., 359 degrees "
                             "(the glimpses' mixture weights)"] = \
        dataclasses.field(default_factory=_no_likelihood)
    nSources: Annotated[ULong, "Sources found (as asked, or counted when LocalizeSources asked for 0)"] = 0
    sources: Annotated[list[SourceAzimuthData], "The sources, strongest first (azimuth and confidence above "
                                                "are the first's)"] = dataclasses.field(default_factory=list)
    index: Annotated[ULongLong, "Its number in the Estimates history (from 1 since binauloc started)"] = 0


@idl_struct("binauloc::estimates")
class EstimatesData:
    """Estimates of the history, oldest first: a read with since=K holds those after estimate K.

    Each estimate has one element in the per-estimate arrays, and MAX_SOURCES (6) consecutive
    elements in the per-source arrays, the sources strongest first, NaN after the nSources found.
    """

    last: Annotated[ULongLong, "The newest estimate's number (estimates are numbered from 1 since binauloc "
                               "started)"] = 0
    nEstimates: Annotated[ULong, "Estimates in this read"] = 0
    estimate: Annotated[NDArray[np.uint64], "Each estimate's number"] = dataclasses.field(default_factory=_no_numbers)
    frameIndex: Annotated[NDArray[np.uint64], "The last frame each rests on, numbered as the connected port numbers "
                                              "them"] = dataclasses.field(default_factory=_no_numbers)
    nFrames: Annotated[NDArray[np.uint32], "Analysis frames each rests on"] = \
        dataclasses.field(default_factory=_no_counts)
    headAzimuth: Annotated[NDArray[np.float64], "The head's room azimuth at each one's last frame, radians (NaN: "
                                                "unknown)"] = dataclasses.field(default_factory=_no_likelihood)
    nSources: Annotated[NDArray[np.uint32], "Sources each names"] = dataclasses.field(default_factory=_no_counts)
    azimuth: Annotated[NDArray[np.float64], "Per source: radians in the head frame"] = \
        dataclasses.field(default_factory=_no_likelihood)
    roomAzimuth: Annotated[NDArray[np.float64], "Per source: radians in the room (NaN: unknown)"] = \
        dataclasses.field(default_factory=_no_likelihood)
    confidence: Annotated[NDArray[np.float64], "Per source: as Azimuths' sources"] = \
        dataclasses.field(default_factory=_no_likelihood)
    weight: Annotated[NDArray[np.float64], "Per source: its share of the glimpses"] = \
        dataclasses.field(default_factory=_no_likelihood)
    power: Annotated[NDArray[np.float64], "Per source: its share of the glimpses' power"] = \
        dataclasses.field(default_factory=_no_likelihood)


@idl_struct("binauloc::source")
class SourceData:
    """The source FaceSource found and faces: every frame at its head azimuth, combined in the room."""

    roomAzimuth: Annotated[Double, Unit("rad"), "The source's azimuth in the room, radians (positive = left)"] = 0.0
    confidence: Annotated[Double, "Posterior probability within 10 degrees of it"] = 0.0
    headAzimuth: Annotated[Double, Unit("rad"), "Where the head is now, radians in the room"] = 0.0
    faced: Annotated[Boolean, "Whether the head faces the source (false when it lies beyond the head's limits)"] = \
        False
    turns: Annotated[ULong, "Head azimuths looked from besides the first"] = 0
    estimates: Annotated[ULong, "Estimates combined"] = 0
    logLikelihood: Annotated[LogLikelihood, Grid(0, 1, "deg"),
                             "Log of the sources' distribution over room azimuths 0, 1, ..., 359 degrees"] = \
        dataclasses.field(default_factory=_no_likelihood)
    sources: Annotated[list[SourceAzimuthData], "Every source found, strongest first"] = \
        dataclasses.field(default_factory=list)


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
