"""What a simulated sound scene takes from the components around it: the head it turns with, the room it hears.

Components offer these by type on their host (``self.provide(HeadAzimuth, ...)``); a capture of
the ``sim`` device finds them there, whichever component provides them: ``kemar`` for its
simulated drive, ``morse_kemar`` for the KEMAR of the virtual world.  Neither side names the other.
"""

from __future__ import annotations

import asyncio
import dataclasses
import logging
from collections.abc import Callable

from ..core import Clock, ComponentHost
from ..recording import replay_roots
from ._backend import (
    Azimuth, CaptureBackend, ListenerPosition, SourceAzimuths, SourceOptions, backend_class, split_device,
)
from ._errors import DeviceError
from ._scene import Scene

__all__ = ["HeadAzimuth", "SoundScene", "open_for_host", "prepare_for_host"]

log = logging.getLogger(__name__)


@dataclasses.dataclass(frozen=True)
class HeadAzimuth:
    """A simulated head's azimuth, which a simulated sound scene follows.

    Attributes:
        read: Returns the azimuth now, in degrees, positive to the left; callable from any thread.
    """

    read: Callable[[], float]


@dataclasses.dataclass(frozen=True)
class SoundScene:
    """The sources a capture of plain ``sim`` renders, instead of the default scene (those of a simulated room).

    Attributes:
        scene: The scene (a scene file, ``sim:PATH``, still wins).
        azimuths: For a listener that moves through the room (a robot's base), the sources' room
            azimuths now, in degrees, one per source of *scene*; read at every chunk, from any
            thread.  None: the scene's azimuths, fixed.  A scene in metres ignores them.
        listener: For a scene in metres, where the robot's head is now: (x, y, z) in the room
            frame, metres; read at every chunk, from any thread.  None: the scene's listener.
    """

    scene: Scene
    azimuths: SourceAzimuths | None = None
    listener: ListenerPosition | None = None


def open_for_host(host: ComponentHost, device: str, rate: int, frames_per_chunk: int, clock: Clock, *,
                  azimuth: Azimuth | None = None) -> CaptureBackend:
    """The backend (not yet open) of *device* for a component of *host*.

    Files come from the directories of the host's settings (``audio_files``; recordings, ``mcap:PATH``,
    from ``record_dirs`` too).  A simulated
    scene turns with the :class:`HeadAzimuth` some component of the host provides, looked up at
    every chunk (so a head loaded after the capture started is followed too; 0° while there is
    none), unless *azimuth* is given (a script steering the scene); plain ``sim`` renders the
    host's :class:`SoundScene` if one is provided (its sources moving as it says).

    Raises:
        DeviceError: for a device string holding a control character (a NUL cuts a name short
            in the C libraries below: no device is named so).
    """
    if any(ord(c) < 32 or ord(c) == 127 for c in device):
        raise DeviceError(f"a device name holds no control characters, not {device!r}")
    kind, argument = split_device(device)
    scene = None
    source_azimuths = None
    listener = None
    if kind == "sim":
        if azimuth is None:
            azimuth = _follow(host)
        provided = host.find(SoundScene)
        if provided is not None:
            scene, source_azimuths, listener = provided.scene, provided.azimuths, provided.listener
    else:
        azimuth = None  # real microphones hear the real room
    options = SourceOptions(azimuth=azimuth, roots=_file_roots(host, kind), scene=scene,
                            source_azimuths=source_azimuths, listener=listener)
    return backend_class(kind).for_device(device, argument, rate, frames_per_chunk, clock, options)


def _file_roots(host: ComponentHost, kind: str) -> tuple[str, ...] | None:
    """The directories a backend of *kind* may open files from (None: anywhere, a host built in code)."""
    settings = host.settings
    return replay_roots(settings.record_dirs, settings.audio_files) if kind == "mcap" else settings.audio_files


def _follow(host: ComponentHost) -> Azimuth:
    def azimuth() -> float:
        head = host.find(HeadAzimuth)
        return head.read() if head is not None else 0.0

    return azimuth


async def prepare_for_host(host: ComponentHost, clock: Clock, rate: int) -> None:
    """When the host's default device is simulated, tabulate the measured KEMAR's filters at *rate* now.

    A capture component calls it as it loads, so that its first ``sim`` capture at that rate starts
    at once rather than after a tenth of a second (off the event loop, simulated time held). When
    the HRIRs cannot be read, it says so in the log; the capture then reports it as it opens.
    """
    if split_device(host.settings.audio_device)[0] != "sim":
        return
    from ..binaural import BinauralError
    from ._renderers import prepare_kemar

    try:
        with clock.holding():
            await asyncio.to_thread(prepare_kemar, rate)
    except BinauralError as exc:
        log.warning("the simulated scene cannot hear through the measured KEMAR: %s", exc)
