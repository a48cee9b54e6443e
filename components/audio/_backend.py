"""The capture backend interface, the clock-paced base, and the table of backends by device string.

Device strings::

    sim                  the default simulated binaural scene
    sim:<scene.json>     a simulated scene from a JSON file (see _scene)
    file:<path.wav>      a WAV file played at the capture rate, ending with the file
    mcap:<path.mcap>     a recording's audio played again at its rate (``#instance/port`` picks one)
    pa | pa:<name|index> a PortAudio input device (``portaudio:`` works too)
    alsa:<name> | <name> an ALSA PCM: hw:1,0, plughw:1,0, default, null, ...
    <prefix>:<argument>  a backend of another package (an ``aiogenomix.capture_backends`` entry point)

Any other ``PREFIX:`` is refused (:class:`UnknownDevicePrefix`, naming the prefixes there are).

Every backend hands out :class:`Chunk` objects of exactly ``frames_per_chunk``
int32 stereo frames with the time of their first frame, and says in each
chunk whether frames were lost before it.
"""

from __future__ import annotations

import abc
import dataclasses
import importlib
import importlib.metadata
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, ClassVar, Self

import numpy as np
import numpy.typing as npt

from ..core import Clock
from ._errors import UnknownDevicePrefix

if TYPE_CHECKING:
    from ._scene import Scene

__all__ = [
    "Chunk", "CaptureBackend", "PacedBackend", "SourceOptions", "BACKENDS", "backend_class", "open_backend",
    "split_device", "known_prefixes", "UnknownDevicePrefix", "CAPTURE_BACKENDS", "ALSA_PCM_PREFIXES",
    "Azimuth", "SourceAzimuths", "ListenerPosition",
]

#: A callable giving the current head azimuth in degrees (positive to the left).
Azimuth = Callable[[], float]
#: A callable giving the sources' room azimuths now, in degrees (a listener that moves through a room).
SourceAzimuths = Callable[[], Sequence[float]]
#: A callable giving where the listening head's centre is now: (x, y, z) in the room frame, metres.
ListenerPosition = Callable[[], Sequence[float]]


@dataclasses.dataclass(frozen=True)
class SourceOptions:
    """What a backend may use besides its device string.

    Attributes:
        azimuth: Head azimuth source of a simulated scene (None: 0°).
        roots: The directories WAV and scene files may come from (the gateway's
            ``--audio-files``); None allows any path (a host built in code).
        scene: The scene of plain ``sim`` (None: :data:`DEFAULT_SCENE`).
        source_azimuths: The room azimuths of *scene*'s sources now (None: the scene's, fixed).
        listener: Where the head of *scene* is now, metres (None: the scene's listener).
    """

    azimuth: Azimuth | None = None
    roots: Sequence[str] | None = None
    scene: Scene | None = None
    source_azimuths: SourceAzimuths | None = None
    listener: ListenerPosition | None = None


@dataclasses.dataclass(frozen=True)
class Chunk:
    """One chunk of captured frames.

    Attributes:
        frames: ``(frames_per_chunk, 2)`` int32 frames, left then right.
        time: POSIX time (on the runtime clock) of the first frame.
        overrun: Whether the device or the hand-over lost data just before this chunk.
        lost_frames: How many frames were lost just before this chunk (an
            estimate after a device overrun; exact when the hand-over dropped chunks).
        head_azimuth: The head's azimuth at the chunk's end (degrees, positive to the left) when the
            source knows it: a recording played again gives the recorded one. None: the source does not
            know it (a component that publishes azimuths reads its head).
    """

    frames: npt.NDArray[np.int32]
    time: float
    overrun: bool = False
    lost_frames: int = 0
    head_azimuth: float | None = None

    @property
    def left(self) -> npt.NDArray[np.int32]:
        """The left channel (a view)."""
        return self.frames[:, 0]

    @property
    def right(self) -> npt.NDArray[np.int32]:
        """The right channel (a view)."""
        return self.frames[:, 1]


class CaptureBackend(abc.ABC):
    """A source of chunks: open it, read chunks, close it.

    Use as ``async with backend: async for chunk in backend: ...``.

    Args:
        device: The device string (for messages).
        rate: Frames per second.
        frames_per_chunk: Frames in each chunk (the ALSA period).
        clock: The runtime clock used for timestamps and, for simulated
            sources, pacing.
    """

    #: The backend's name in messages (``ALSA``, ``PortAudio``, ...).
    kind: ClassVar[str] = "capture"

    @classmethod
    @abc.abstractmethod
    def for_device(cls, device: str, argument: str, rate: int, frames_per_chunk: int, clock: Clock,
                   options: SourceOptions) -> Self:
        """The backend (not yet open) for *device*, whose part after the backend's prefix is *argument*."""

    def __init__(self, device: str, rate: int, frames_per_chunk: int, clock: Clock) -> None:
        self.device = device
        self.rate = rate
        self.frames_per_chunk = frames_per_chunk
        self.clock = clock
        #: Overrun events reported so far.
        self.overruns = 0
        #: Frames lost so far (as reported with the chunks).
        self.lost_frames = 0
        self._closed = False

    @property
    def chunk_duration(self) -> float:
        """Seconds of audio per chunk."""
        return self.frames_per_chunk / self.rate

    @abc.abstractmethod
    async def open(self) -> None:
        """Open and start the device.

        Raises:
            DeviceNotFound: when the device does not exist.
            BackendUnavailable: when the backend's library is missing.
            DeviceError: when the device refuses the configuration.
        """

    @abc.abstractmethod
    async def _read(self) -> Chunk | None:
        """Wait for the next chunk (None at the end of a finite source)."""

    async def read(self) -> Chunk | None:
        """Wait for the next chunk; None when a finite source (a file) has ended.

        Raises:
            DeviceError: when the device fails.
        """
        chunk = await self._read()
        if chunk is not None and chunk.overrun:
            self.overruns += 1
            self.lost_frames += chunk.lost_frames
        return chunk

    @abc.abstractmethod
    async def _close(self) -> None:
        """Stop and release the device."""

    async def aclose(self) -> None:
        """Stop and release the device (idempotent)."""
        if not self._closed:
            self._closed = True
            await self._close()

    async def __aenter__(self) -> Self:
        await self.open()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.aclose()

    def __aiter__(self) -> Self:
        return self

    async def __anext__(self) -> Chunk:
        chunk = await self.read()
        if chunk is None:
            raise StopAsyncIteration
        return chunk

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.device!r} {self.rate} Hz, {self.frames_per_chunk} frames/chunk>"


class PacedBackend(CaptureBackend):
    """A generated source released in real time by the runtime clock.

    Chunk *k* (from 0) covers ``[k·T, (k+1)·T)`` after the start and is released
    when the clock reaches its end, as a sound card would deliver it.  A reader
    that falls behind gets the late chunks at once, so nothing is dropped.
    """

    def __init__(self, device: str, rate: int, frames_per_chunk: int, clock: Clock) -> None:
        super().__init__(device, rate, frames_per_chunk, clock)
        self._origin = 0.0
        self._start_wall = 0.0
        self._produced = 0

    async def open(self) -> None:
        self._origin = self.clock.now()
        self._start_wall = self.clock.wall()

    @abc.abstractmethod
    def _produce(self, count: int) -> npt.NDArray[np.int32] | None:
        """Generate the next *count* frames (None at the end of the source)."""

    async def _frames(self, count: int) -> npt.NDArray[np.int32] | None:
        """The next *count* frames when their chunk is due: :meth:`_produce`'s, made on the event loop.

        A source whose frames take long to make (a scene rendered in a room) makes them
        elsewhere, as a sound card's driver fills its buffer in a thread of its own.
        """
        return self._produce(count)

    async def _read(self) -> Chunk | None:
        index = self._produced
        await self.clock.sleep_until(self._origin + (index + 1) * self.chunk_duration)
        frames = await self._frames(self.frames_per_chunk)
        if frames is None:
            return None
        self._produced += 1
        return Chunk(frames, self._start_wall + index * self.chunk_duration)

    async def _close(self) -> None:
        pass


#: The backends by the kind of device they open, as ``module:class``, imported on first use (as
#: python-can's table of interfaces): a capture loads the library of its own backend only.
BACKENDS: dict[str, str] = {
    "sim": "._sim_backend:SimulatedSceneBackend",
    "file": "._wav_backend:WavFileBackend",
    "mcap": "._mcap_backend:RecordingBackend",
    "portaudio": "._portaudio:PortAudioBackend",
    "alsa": "._alsa:AlsaBackend",
}

#: Device string prefixes and the kind of backend they name.
_PREFIXES = {"sim": "sim", "file": "file", "mcap": "mcap", "alsa": "alsa", "pa": "portaudio",
             "portaudio": "portaudio"}
#: ALSA's own PCM names that take arguments after a colon (``hw:1,0``, ``plughw:CARD=USB``): ALSA
#: opens these.  Any other ``PREFIX:`` names no backend; a name without a colon is ALSA's (``default``).
ALSA_PCM_PREFIXES = frozenset({
    "hw", "plughw", "default", "sysdefault", "front", "rear", "center_lfe", "side", "surround21", "surround40",
    "surround41", "surround50", "surround51", "surround71", "iec958", "spdif", "hdmi", "dmix", "dsnoop", "dshare",
    "plug", "asym", "null", "pulse", "pipewire", "jack", "usbstream", "shm",
})
#: The entry point group through which other packages add capture backends: each entry point's name is
#: its device prefix, its value the backend class (``my_rig.capture:MyBackend``), imported on first use.
CAPTURE_BACKENDS = "aiogenomix.capture_backends"


def _installed() -> dict[str, importlib.metadata.EntryPoint]:
    """The capture backends of other packages by device prefix (the built-in prefixes are kept for ours)."""
    return {entry.name: entry for entry in importlib.metadata.entry_points(group=CAPTURE_BACKENDS)
            if entry.name not in _PREFIXES}


def known_prefixes() -> list[str]:
    """Every device prefix a capture opens: the built-in ones and those of other packages' backends."""
    return sorted({*_PREFIXES, *_installed()})


def split_device(device: str) -> tuple[str, str]:
    """Split a device string into ``(backend, argument)``.

    >>> split_device("hw:1,0"), split_device("sim"), split_device("pa:2")
    (('alsa', 'hw:1,0'), ('sim', ''), ('portaudio', '2'))

    Raises:
        UnknownDevicePrefix: for a ``PREFIX:`` that names no backend, naming those that do.
    """
    head, colon, tail = device.partition(":")
    kind = _PREFIXES.get(head)
    if kind is not None:
        return kind, tail
    if head in _installed():  # (another package's prefix is taken before ALSA's names)
        return head, tail
    if not colon or head in ALSA_PCM_PREFIXES:
        return "alsa", device
    raise UnknownDevicePrefix(device, head, known_prefixes())


def backend_class(kind: str) -> type[CaptureBackend]:
    """The backend class of *kind* (a key of :data:`BACKENDS`, or another package's prefix), imported now.

    Raises:
        KeyError: for a kind that no table has.
        TypeError: for another package's entry point that names no :class:`CaptureBackend`.
    """
    if kind in BACKENDS:
        module, _, name = BACKENDS[kind].partition(":")
        cls = getattr(importlib.import_module(module, __package__), name)
    else:
        entry = _installed()[kind]
        cls = entry.load()
        if not (isinstance(cls, type) and issubclass(cls, CaptureBackend)):
            raise TypeError(f"the {CAPTURE_BACKENDS} entry point {kind} ({entry.value}) is not a CaptureBackend")
    assert isinstance(cls, type) and issubclass(cls, CaptureBackend)
    return cls


def open_backend(device: str, rate: int, frames_per_chunk: int, clock: Clock, *,
                 azimuth: Azimuth | None = None, roots: Sequence[str] | None = None,
                 scene: Scene | None = None) -> CaptureBackend:
    """Create (not yet open) the backend a device string names.

    Args:
        device: See the module docstring.
        rate: Frames per second.
        frames_per_chunk: Frames per chunk.
        clock: The runtime clock.
        azimuth: Head azimuth source for the simulated scene (default: 0°).
        roots: The directories WAV and scene files may come from (the gateway's
            ``--audio-files``); None allows any path (a host built in code).
        scene: The scene of plain ``sim`` (default: :data:`DEFAULT_SCENE`).

    Nothing is opened here: a backend touches its device or file in ``open()``,
    off the event loop.
    """
    kind, argument = split_device(device)
    return backend_class(kind).for_device(device, argument, rate, frames_per_chunk, clock,
                                          SourceOptions(azimuth, roots, scene))
