"""The bounds of a capture, shared by the audio stream servers of both generations."""

from __future__ import annotations

__all__ = ["MAX_PORT_BYTES", "RATE_RANGE", "MAX_FRAMES_PER_CHUNK"]

#: The largest port accepted (both channels, int32).
MAX_PORT_BYTES = 256 * 2**20
#: Sample rates a capture may ask for, in Hz.
RATE_RANGE = (1000, 384_000)
#: The largest chunk, in frames (about 2.7 s at 384 kHz).
MAX_FRAMES_PER_CHUNK = 2**20
