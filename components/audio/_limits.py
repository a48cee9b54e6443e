"""The bounds of a capture, shared by the audio stream servers of both generations.

The size of a port is a budget of the host (``settings.budgets.port_bytes``, ``--max-port-bytes``).
"""

from __future__ import annotations

__all__ = ["RATE_RANGE", "MAX_FRAMES_PER_CHUNK"]

#: Sample rates a capture may ask for, in Hz.
RATE_RANGE = (1000, 384_000)
#: The largest chunk, in frames (about 2.7 s at 384 kHz).
MAX_FRAMES_PER_CHUNK = 2**20
