"""What a simulated sound scene takes from the components around it: the head it turns with, the room it hears.

Components offer these by type on their host (``self.provide(HeadAzimuth, ...)``); a capture of
the ``sim`` device finds them there, whichever component provides them: ``kemar`` for its
simulated drive, ``morse_kemar`` for the KEMAR of the virtual world.  Neither side names the other.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

from ..core import Clock, ComponentHost
from ._backend import Azimuth, CaptureBackend, SourceOptions, backend_class, split_device
from ._scene import Scene

__all__ = ["HeadAzimuth", "SoundScene", "open_for_host"]


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
    """

    scene: Scene


def open_for_host(host: ComponentHost, device: str, rate: int, frames_per_chunk: int, clock: Clock, *,
                  azimuth: Azimuth | None = None) -> CaptureBackend:
    """The backend (not yet open) of *device* for a component of *host*.

    Files come from the directories of the host's settings (``audio_files``; recordings, ``mcap:PATH``,
    from ``record_dirs`` too).  A simulated
    scene turns with the :class:`HeadAzimuth` some component of the host provides, looked up at
    every chunk (so a head loaded after the capture started is followed too; 0° while there is
    none), unless *azimuth* is given (a script steering the scene); plain ``sim`` renders the
    host's :class:`SoundScene` if one is provided.
    """
    kind, argument = split_device(device)
    scene = None
    if kind == "sim":
        if azimuth is None:
            azimuth = _follow(host)
        provided = host.find(SoundScene)
        scene = provided.scene if provided is not None else None
    else:
        azimuth = None  # real microphones hear the real room
    options = SourceOptions(azimuth=azimuth, roots=_file_roots(host, kind), scene=scene)
    return backend_class(kind).for_device(device, argument, rate, frames_per_chunk, clock, options)


def _file_roots(host: ComponentHost, kind: str) -> tuple[str, ...] | None:
    """The directories a backend of *kind* may open files from (None: anywhere, a host built in code)."""
    settings = host.settings
    if kind != "mcap":
        return settings.audio_files
    if settings.audio_files is None or settings.record_dirs is None:
        return None
    return (*settings.audio_files, *settings.record_dirs)


def _follow(host: ComponentHost) -> Azimuth:
    def azimuth() -> float:
        head = host.find(HeadAzimuth)
        return head.read() if head is not None else 0.0

    return azimuth
