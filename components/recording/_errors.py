"""The recording library's exceptions: one tree, turned into their genom3 exceptions by the components."""

from __future__ import annotations

__all__ = ["RecordingError", "PathRefused", "NotARecording"]


class RecordingError(Exception):
    """A recording cannot be made or read (the message says why, for a user to read)."""


class PathRefused(RecordingError, PermissionError):
    """A path outside the directories the operator allowed for recordings (or recordings disabled)."""


class NotARecording(RecordingError):
    """A file that is not an MCAP recording, or lacks what was asked of it (no audio, another rate)."""
