"""The simulated binaural capture backend: a scene rendered at a turning head (the measured KEMAR by default)."""

from __future__ import annotations

import asyncio
from collections.abc import Sequence
from typing import Self

import numpy as np
import numpy.typing as npt

from ..binaural import BinauralError
from ..core import Clock
from ._backend import Azimuth, ListenerPosition, PacedBackend, SourceAzimuths, SourceOptions
from ._errors import BackendUnavailable
from ._paths import confined_path
from ._renderers import SceneRenderer, scene_renderer
from ._scene import DEFAULT_SCENE, Scene, load_scene

__all__ = ["SimulatedSceneBackend"]


#: The sources' room azimuths now (degrees), or None where the scene's stay.
SourceAzimuthsNow = Sequence[float] | None
#: The listener's place now (metres), or None where the scene's stays.
ListenerNow = Sequence[float] | None


def _facing_front() -> float:
    return 0.0


class SimulatedSceneBackend(PacedBackend):
    """Virtual sources heard by a head that may turn: the measured KEMAR, or the spherical head a scene names.

    The head azimuth (and the sources' azimuths of a listener that moves through a
    room) is read once per chunk, when the chunk is produced (its end), and the
    rendering moves smoothly from the previous azimuths to it.

    Args:
        device: The device string.
        rate: Frames per second.
        frames_per_chunk: Frames per chunk.
        clock: The runtime clock that paces the chunks.
        scene_file: A JSON scene file (None: :data:`DEFAULT_SCENE`).
        scene: A scene object (takes precedence over *scene_file*).
        azimuth: The head azimuth in degrees (default: always 0°).
        roots: The directories a scene file may come from (None: anywhere).
        source_azimuths: The sources' room azimuths now, degrees (None: the scene's, fixed).
        listener: Where the head's centre is now, metres (None: the scene's listener); scenes in metres.

    The scene file is read and the renderer built (its filters tabulated) by :meth:`open`,
    off the event loop and with simulated time held still; the capture's clock starts before.
    """

    kind = "simulated scene"

    @classmethod
    def for_device(cls, device: str, argument: str, rate: int, frames_per_chunk: int, clock: Clock,
                   options: SourceOptions) -> Self:
        """The scene file *argument* (``sim:PATH``), or the options' scene for plain ``sim``."""
        provided = None if argument else options.scene
        return cls(device, rate, frames_per_chunk, clock, scene_file=argument or None, scene=provided,
                   azimuth=options.azimuth, roots=options.roots,
                   source_azimuths=options.source_azimuths if provided is not None else None,
                   listener=options.listener if provided is not None else None)

    def __init__(self, device: str, rate: int, frames_per_chunk: int, clock: Clock, *,
                 scene_file: str | None = None, scene: Scene | None = None,
                 azimuth: Azimuth | None = None, roots: Sequence[str] | None = None,
                 source_azimuths: SourceAzimuths | None = None, listener: ListenerPosition | None = None) -> None:
        super().__init__(device, rate, frames_per_chunk, clock)
        self.listener = listener
        self.scene_file = scene_file
        self.scene = scene if scene is not None else (None if scene_file else DEFAULT_SCENE)
        self.azimuth = azimuth or _facing_front
        self.source_azimuths = source_azimuths
        self._roots = roots
        self.renderer: SceneRenderer | None = None
        self._rendered_first = False

    async def open(self) -> None:
        """Read the scene file (if any), build the renderer and start the clock.

        Raises:
            PathRefused: for a scene file outside the allowed directories.
            SceneError: for a scene file that cannot be used.
            BackendUnavailable: when the measured HRIRs cannot be read.
        """
        # The capture starts now: building the renderer (a tenth of a second at a new rate) does not shift
        # its clock. On a real or scaled clock the chunks due meanwhile come at once when it is built, as a
        # sound card's buffer holds them; simulated time stands still meanwhile.
        await super().open()
        with self.clock.holding():
            self.renderer = await asyncio.to_thread(self._build)

    def _build(self) -> SceneRenderer:
        if self.scene is None:
            assert self.scene_file is not None
            self.scene = load_scene(confined_path(self.scene_file, self._roots), shown=self.scene_file)
        try:
            return scene_renderer(self.scene, self.rate, roots=self._roots)
        except BinauralError as exc:
            raise BackendUnavailable(f"the simulated KEMAR cannot hear: {exc}") from exc

    def _produce(self, count: int) -> npt.NDArray[np.int32]:
        return self._render(count, *self._pose())

    async def _frames(self, count: int) -> npt.NDArray[np.int32]:
        """The next chunk, the head and the sources where they are now (read here, on the event loop).

        Rendered in a thread, with simulated time held still, so that the gateway's event loop
        goes on meanwhile: the first chunk of a room makes its reflections and its tail from
        where everybody is (about 100 ms), and each chunk after it takes 4-7 ms for a room with
        a few talkers, which the loop spent 20 times a second.  Only on a rig that runs faster
        than real time are the chunks after the first rendered on the loop: there the render
        fills most of a chunk's real period, and a thread, sharing the interpreter's lock with
        the loop at every step, fell behind the rig's clock (bass at 20 times real time).
        """
        if self._rendered_first and self.clock.scale > 1.0:
            return self._produce(count)
        pose = self._pose()
        with self.clock.holding():
            frames = await asyncio.to_thread(self._render, count, *pose)
        self._rendered_first = True
        return frames

    def _pose(self) -> tuple[float, SourceAzimuthsNow, ListenerNow]:
        """The head's azimuth, the sources' azimuths and the listener's place now (None where the scene's stay)."""
        sources = self.source_azimuths() if self.source_azimuths is not None else None
        listener = self.listener() if self.listener is not None else None
        return float(self.azimuth()), sources, listener

    def _render(self, count: int, head: float, sources: SourceAzimuthsNow, listener: ListenerNow
                ) -> npt.NDArray[np.int32]:
        assert self.renderer is not None, "read before open"
        return self.renderer.render(count, head, sources, listener)
