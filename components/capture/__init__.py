"""The ``capture`` component: the binaural audio stream server (seed chapter 5), on the audio library.

Backends, scenes, the chunk window and the dedicated socket live in :mod:`aiogenomix.components.audio`;
here are the component, its IDL types and exceptions, and :class:`PortView`, the form in which it
publishes ``Port`` (a merged component that publishes its own port struct uses it too).
"""

from ._component import Capture, HeadPositionSource, frames_per_chunk
from ._port_view import PortView
from ._types import (
    ALREADY_CAPTURING, DEVICE_ERROR, ERROR_SEQUENCE_ENOMEM, INVALID_CHUNK_TIME, NO_SUCH_DEVICE, SOCKET_ERROR,
    PORT_AUDIO, CaptureConfig, CaptureStatus, PortData, Timestamp,
)

__all__ = [
    # The component and its port
    "Capture", "HeadPositionSource", "PortView", "PortData", "PORT_AUDIO", "Timestamp", "CaptureConfig",
    "CaptureStatus", "frames_per_chunk",
    # Exceptions
    "INVALID_CHUNK_TIME", "ERROR_SEQUENCE_ENOMEM", "NO_SUCH_DEVICE", "DEVICE_ERROR", "ALREADY_CAPTURING",
    "SOCKET_ERROR",
]
