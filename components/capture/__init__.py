"""The ``capture`` component (binaural audio stream server), its capture backends and the dedicated socket."""

from ._backend import Azimuth, CaptureBackend, Chunk, PacedBackend, open_backend, split_device
from ._component import MAX_FRAMES_PER_CHUNK, MAX_PORT_BYTES, RATE_RANGE, Capture, HeadPositionSource, frames_per_chunk
from ._errors import (
    BackendUnavailable, CaptureError, DeviceError, DeviceNotFound, FormatRefused, RequestError, SceneError,
)
from ._devices import list_capture_devices
from ._head_link import scene_azimuth, simulated_head_azimuth, simulated_scene
from ._line_server import CLOSE, TOKEN_PREFIX, Conversation, LastReply, LineServer, split_lines
from ._head_model import SphericalHeadRenderer, woodworth_itd
from ._scene import DEFAULT_SCENE, Scene, Source, load_scene
from ._socket_server import DedicatedSocketServer
from ._socket_wire import (
    RequestParser, encode_error, encode_reply, encode_request, parse_request, reply_size,
)
from ._types import (
    ALREADY_CAPTURING, DEVICE_ERROR, ERROR_SEQUENCE_ENOMEM, INVALID_CHUNK_TIME, NO_SUCH_DEVICE, SOCKET_ERROR,
    CaptureConfig, CaptureStatus, PortData, Timestamp,
)
from ._window import ChunkWindow, WindowRead

__all__ = [
    # The component and its types
    "Capture", "HeadPositionSource", "MAX_PORT_BYTES", "MAX_FRAMES_PER_CHUNK", "RATE_RANGE",
    "PortData", "Timestamp", "CaptureConfig", "CaptureStatus", "frames_per_chunk",
    "INVALID_CHUNK_TIME", "ERROR_SEQUENCE_ENOMEM", "NO_SUCH_DEVICE", "DEVICE_ERROR", "ALREADY_CAPTURING",
    "SOCKET_ERROR",
    # Backends
    "CaptureBackend", "PacedBackend", "Chunk", "Azimuth", "open_backend", "split_device",
    # The simulated scene
    "Scene", "Source", "DEFAULT_SCENE", "load_scene", "SphericalHeadRenderer", "woodworth_itd",
    # The chunk window and the dedicated socket
    "ChunkWindow", "WindowRead", "DedicatedSocketServer", "LineServer", "LastReply", "Conversation", "split_lines",
    "CLOSE", "TOKEN_PREFIX", "RequestParser", "parse_request", "encode_request",
    "encode_reply", "encode_error", "reply_size",
    # Errors
    "CaptureError", "DeviceNotFound", "BackendUnavailable", "DeviceError", "FormatRefused", "SceneError",
    "RequestError",
    # The simulated head the scene follows
    "simulated_head_azimuth", "scene_azimuth", "simulated_scene", "list_capture_devices",
]
