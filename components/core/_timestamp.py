"""Timestamps published on ports: a POSIX time as ``{tv_sec, tv_nsec}``, the way genom3 components carry it."""

from __future__ import annotations

import dataclasses
import math
from typing import Self

from ._types import Long

__all__ = ["Timestamp"]


@dataclasses.dataclass
class Timestamp:
    """A POSIX time split into seconds and nanoseconds.

    Components declare their own IDL name for it by subclassing:
    ``@idl_struct("capture::timestamp_t") class Timestamp(core.Timestamp): ...``.
    """

    tv_sec: Long = 0
    tv_nsec: Long = 0

    @classmethod
    def from_seconds(cls, seconds: float) -> Self:
        """Split a POSIX time in seconds."""
        whole = math.floor(seconds)
        return cls(tv_sec=whole, tv_nsec=min(999_999_999, round((seconds - whole) * 1e9)))

    def seconds(self) -> float:
        """The time as POSIX seconds."""
        return self.tv_sec + self.tv_nsec * 1e-9
