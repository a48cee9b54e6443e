"""When a port's data was captured, and its numbers: read once for the recording and the live view alike.

What the data *is* (audio, a head's state, a picture...) its type declares (its port kind,
:class:`~aiogenomix.components.core.PortKind`), and each kind reads its own members; what any
data may say of its time is read here.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from ..core import seconds_of

__all__ = ["seconds_of", "stamp_of", "number"]


def stamp_of(data: Any) -> float | None:
    """The capture time a port's data carries: a ``timestamp``, ``stamp`` or ``ts`` member, or its header's stamp."""
    if not isinstance(data, Mapping):
        return None
    for key in ("timestamp", "stamp", "ts"):
        seconds = seconds_of(data.get(key))
        if seconds is not None and isinstance(data.get(key), Mapping):
            return seconds
    header = data.get("header")
    if isinstance(header, Mapping):
        stamp = header.get("stamp")
        return seconds_of(stamp) if isinstance(stamp, Mapping) else None
    return None


def number(value: Any) -> float:
    """A number of JSON data, where ``null`` stands for NaN (JSON has no NaN)."""
    return math.nan if value is None else float(value)
