"""The ``bass`` component (the 2015 Two!Ears binaural audio stream server), its frame-indexed port and socket."""

from ._component import Bass
from ._history import AudioSnapshot, ChunkHistory, FrameRead
from ._socket_server import FrameSocketServer
from ._socket_wire import (
    HEADER, FrameRequest, FrameRequestParser, encode_frame_reply, encode_frame_request, frame_reply_size,
    parse_frame_request,
)
from ._types import AudioPortData, Samples, e_device, e_hwparams, e_nodevice, e_nomem, e_socket, e_swparams

__all__ = [
    # The component and its port
    "Bass", "AudioPortData", "Samples", "AudioSnapshot", "ChunkHistory", "FrameRead",
    # Exceptions
    "e_nomem", "e_nodevice", "e_device", "e_hwparams", "e_swparams", "e_socket",
    # The 2015 dedicated socket
    "FrameSocketServer", "FrameRequest", "FrameRequestParser", "parse_frame_request", "encode_frame_request",
    "encode_frame_reply", "frame_reply_size", "HEADER",
]
