"""The audio library under the audio stream servers: capture backends, simulated scenes, the chunk window, sockets.

``capture``, ``kemarcapture``, ``bass`` and ``basc`` are thin components on it.  What lives here:

* **Backends** chosen by device string (``sim``, ``sim:SCENE.json``, ``file:PATH.wav``,
  ``pa:NAME``, an ALSA name), from a table imported lazily (:data:`BACKENDS`), as
  python-can keeps its interfaces: a capture loads the sound library it uses, no other.  Other
  packages add backends by device prefix (``aiogenomix.capture_backends`` entry points); a prefix
  no backend has is refused, naming those there are (:class:`UnknownDevicePrefix`).
* **Simulated scenes**: sources rendered at a head that turns with the :class:`HeadAzimuth` some
  component provides: through the measured KEMAR HRIRs by default (:class:`KemarSceneRenderer`, on
  :mod:`aiogenomix.components.binaural`), another head's (``snowman``, a SOFA file), or a spherical
  head by name (:class:`SphericalHeadRenderer`); in metres, in a shoebox room, with WAV talkers
  (:class:`RoomSceneRenderer`).
* **The chunk window** of the newest chunks (:class:`ChunkWindow`), read whole or incrementally, and
  **the reader of any audio port** (:class:`AudioReader`): every frame once, read by index.
* **The dedicated sockets**: a line server (:class:`LineServer`, :class:`LastReply`) and the
  2014 protocol (``Read Port - Index <k>``, :class:`DedicatedSocketServer`).
* **One exception tree** (:class:`AudioError`), which the components turn into their genom3 exceptions.
"""

import importlib
from typing import TYPE_CHECKING

from ._backend import (
    BACKENDS, CAPTURE_BACKENDS, Azimuth, CaptureBackend, Chunk, ListenerPosition, PacedBackend, SourceAzimuths,
    SourceOptions, backend_class, known_prefixes, open_backend, split_device,
)
from ._capabilities import HeadAzimuth, SoundScene, open_for_host, prepare_for_host
from ._devices import list_capture_devices
from ._errors import (
    AudioError, BackendUnavailable, DeviceError, DeviceNotFound, FormatRefused, RequestError, SceneError,
    UnknownDevicePrefix,
)
from ._limits import MAX_FRAMES_PER_CHUNK, RATE_RANGE
from ._port_reader import AudioReader, NotAudio
from ._line_server import CLOSE, TOKEN_PREFIX, Conversation, LastReply, LineServer, split_lines
from ._scene import DEFAULT_SCENE, Scene, Source, load_scene
from ._socket_ports import SocketPorts
from ._socket_server import DEFAULT_PORT, DedicatedSocketServer
from ._socket_wire import RequestParser, encode_error, encode_reply, encode_request, parse_request, reply_size
from ._window import ChunkWindow, WindowRead, WindowState

if TYPE_CHECKING:  # the renderers, imported when first named (see __getattr__)
    from ._head_model import SphericalHeadRenderer, sphere_hrirs, woodworth_itd
    from ._renderers import KemarSceneRenderer, SceneRenderer, prepare_kemar, scene_renderer
    from ._room_scene import MeasuredSceneRenderer, RoomSceneRenderer, listener_of, shoebox_of

#: The renderers' names and their modules, which stand on scipy and the HRIR sets: imported when first
#: named, so that a process that only names devices or reads audio ports (a gateway's start, its live
#: view) does not map scipy (half a gateway's resident memory).
_RENDERERS = {
    "SphericalHeadRenderer": "_head_model", "sphere_hrirs": "_head_model", "woodworth_itd": "_head_model",
    "KemarSceneRenderer": "_renderers", "SceneRenderer": "_renderers", "prepare_kemar": "_renderers",
    "scene_renderer": "_renderers",
    "MeasuredSceneRenderer": "_room_scene", "RoomSceneRenderer": "_room_scene", "listener_of": "_room_scene",
    "shoebox_of": "_room_scene",
}


def __getattr__(name: str) -> object:
    """Import a renderer's module when one of its names is first asked for."""
    module = _RENDERERS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value

__all__ = [
    # Backends
    "CaptureBackend", "PacedBackend", "Chunk", "SourceOptions", "Azimuth", "SourceAzimuths", "ListenerPosition",
    "BACKENDS", "CAPTURE_BACKENDS", "known_prefixes", "UnknownDevicePrefix",
    "backend_class",
    "open_backend", "open_for_host", "prepare_for_host", "split_device", "list_capture_devices",
    # What a simulated scene takes from the components around it, by type
    "HeadAzimuth", "SoundScene",
    # Bounds of a capture (its port's size is a budget of the host: settings.budgets.port_bytes)
    "RATE_RANGE", "MAX_FRAMES_PER_CHUNK",
    # Simulated scenes
    "Scene", "Source", "DEFAULT_SCENE", "load_scene", "SceneRenderer", "scene_renderer", "KemarSceneRenderer",
    "prepare_kemar", "SphericalHeadRenderer", "sphere_hrirs", "woodworth_itd", "RoomSceneRenderer",
    "MeasuredSceneRenderer", "shoebox_of", "listener_of",
    # The chunk window, and the reader of any audio port
    "ChunkWindow", "WindowRead", "WindowState", "AudioReader", "NotAudio",
    # The dedicated sockets
    "LineServer", "LastReply", "Conversation", "split_lines", "CLOSE", "TOKEN_PREFIX", "DedicatedSocketServer",
    "SocketPorts",
    "DEFAULT_PORT", "RequestParser", "parse_request", "encode_request", "encode_reply", "encode_error", "reply_size",
    # Errors
    "AudioError", "DeviceNotFound", "BackendUnavailable", "DeviceError", "FormatRefused", "SceneError",
    "RequestError",
]
