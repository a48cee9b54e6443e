"""The IDL types and declared exceptions of the ``recorder`` component."""

from __future__ import annotations

import dataclasses
from typing import Annotated

from ..core import Boolean, Double, GenomException, String, ULongLong, idl_struct

__all__ = ["PortCounts", "RecorderStatus", "PortList", "PATH_REFUSED", "NO_SUCH_PORT", "ALREADY_RECORDING",
           "WRITE_FAILED", "BAD_RECORDING", "OVER_BUDGET"]

PortList = list[String]


@idl_struct("recorder::port_counts")
class PortCounts:
    """What was recorded of one port."""

    port: Annotated[String, "instance/port"] = ""
    publications: Annotated[ULongLong, "Publications (audio: reads) recorded"] = 0
    messages: Annotated[ULongLong, "Messages written for it (audio: two per chunk)"] = 0
    lost_frames: Annotated[ULongLong, "Audio frames missed: the window turned over before they were read"] = 0
    coalesced: Annotated[ULongLong, "Publications replaced before they were read (other ports)"] = 0
    unavailable: Annotated[ULongLong, "Reads that found the data withdrawn by its component (a sensor down): the "
                                      "next publication was waited for"] = 0
    index: Annotated[ULongLong, "Audio: the newest chunk (capture) or frame (bass) recorded"] = 0


@idl_struct("recorder::status")
class RecorderStatus:
    """Where the recording is, or how the last one ended."""

    recording: Annotated[Boolean, "Whether a recording runs"] = False
    path: Annotated[String, "The file, as named within its record directory (--record-dir)"] = ""
    elapsed: Annotated[Double, "Runtime seconds since it started"] = 0.0
    bytes: Annotated[ULongLong, "Bytes written to the file (whole records: what a reader gets)"] = 0
    messages: Annotated[ULongLong, "Messages recorded (audio: two per chunk)"] = 0
    queued: Annotated[ULongLong, "Messages of those not in the file yet (the writer thread writes a chunk at a "
                                 "time)"] = 0
    lost_frames: Annotated[ULongLong, "Audio frames missed, over every audio port"] = 0
    coalesced: Annotated[ULongLong, "Publications of other ports replaced before they were read"] = 0
    unavailable: Annotated[ULongLong, "Reads that found a port's data withdrawn by its component, over every "
                                      "port"] = 0
    ports: Annotated[list[PortCounts], "What was recorded of each port"] = dataclasses.field(default_factory=list)
    ended: Annotated[String, "How the last recording ended (stopped, duration, session ended, or the error)"] = ""


class PATH_REFUSED(GenomException):
    """The path is outside the directories the operator allowed (``--record-dir``), or recordings are disabled."""

    path: String
    what: String


class NO_SUCH_PORT(GenomException):
    """A port to record does not exist (``instance/port`` of a loaded instance's out port)."""

    port: String
    what: String


class ALREADY_RECORDING(GenomException):
    """A recording runs: Stop it first (or load another recorder, ``-i NAME``)."""

    path: String


class BAD_RECORDING(GenomException):
    """The recording cannot be made: the file exists, a directory is missing, a port cannot be recorded."""

    path: String
    what: String


class WRITE_FAILED(GenomException):
    """Writing stopped (the disk is full, a file size limit): the file holds what was written before, readable."""

    path: String
    what: String
    bytes: ULongLong
    seconds: Double


class OVER_BUDGET(GenomException):
    """A budget of the host refused the recording, or ended it: the file keeps what was written before, readable.

    At Start: more recordings at once than ``--max-recordings``, a ``duration`` longer than
    ``--max-recording-seconds``, a record directory that holds ``--max-record-dir-bytes``.  While
    recording: the file reached ``--max-recording-bytes``, the directory ``--max-record-dir-bytes``,
    or a recording until Stop ``--max-recording-seconds``.
    """

    path: String
    what: String
    flag: String
    bytes: ULongLong
    seconds: Double
