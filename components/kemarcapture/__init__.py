"""The ``kemarcapture`` component: binaural capture and the KEMAR head merged, each chunk with the head azimuth."""

from ._component import KemarCapture
from ._types import KemarPortData, MoveIndexes

__all__ = ["KemarCapture", "KemarPortData", "MoveIndexes"]
