"""The simulated binaural capture backend: a scene rendered at a spherical head, paced by the clock."""

from __future__ import annotations

import asyncio
from collections.abc import Sequence
from typing import Self

import numpy as np
import numpy.typing as npt

from ..core import Clock
from ._backend import Azimuth, PacedBackend, SourceOptions
from ._head_model import SphericalHeadRenderer
from ._paths import confined_path
from ._scene import DEFAULT_SCENE, Scene, load_scene

__all__ = ["SimulatedSceneBackend"]


def _facing_front() -> float:
    return 0.0


class SimulatedSceneBackend(PacedBackend):
    """Fixed virtual sources heard by a spherical head that may turn.

    The head azimuth is read once per chunk, when the chunk is produced (its
    end), and the rendering moves smoothly from the previous azimuth to it.

    Args:
        device: The device string.
        rate: Frames per second.
        frames_per_chunk: Frames per chunk.
        clock: The runtime clock that paces the chunks.
        scene_file: A JSON scene file (None: :data:`DEFAULT_SCENE`).
        scene: A scene object (takes precedence over *scene_file*).
        azimuth: The head azimuth in degrees (default: always 0°).
        roots: The directories a scene file may come from (None: anywhere).

    The scene file is read by :meth:`open`, off the event loop.
    """

    kind = "simulated scene"

    @classmethod
    def for_device(cls, device: str, argument: str, rate: int, frames_per_chunk: int, clock: Clock,
                   options: SourceOptions) -> Self:
        """The scene file *argument* (``sim:PATH``), or the options' scene for plain ``sim``."""
        return cls(device, rate, frames_per_chunk, clock, scene_file=argument or None,
                   scene=None if argument else options.scene, azimuth=options.azimuth, roots=options.roots)

    def __init__(self, device: str, rate: int, frames_per_chunk: int, clock: Clock, *,
                 scene_file: str | None = None, scene: Scene | None = None,
                 azimuth: Azimuth | None = None, roots: Sequence[str] | None = None) -> None:
        super().__init__(device, rate, frames_per_chunk, clock)
        self.scene_file = scene_file
        self.scene = scene if scene is not None else (None if scene_file else DEFAULT_SCENE)
        self.azimuth = azimuth or _facing_front
        self._roots = roots
        self.renderer: SphericalHeadRenderer | None = None

    async def open(self) -> None:
        """Read the scene file (if any) and start the clock.

        Raises:
            PathRefused: for a scene file outside the allowed directories.
            SceneError: for a scene file that cannot be used.
        """
        if self.scene is None:
            assert self.scene_file is not None
            self.scene = await asyncio.to_thread(self._load, self.scene_file)
        self.renderer = SphericalHeadRenderer(self.scene, self.rate)
        await super().open()

    def _load(self, path: str) -> Scene:
        return load_scene(confined_path(path, self._roots), shown=path)

    def _produce(self, count: int) -> npt.NDArray[np.int32]:
        assert self.renderer is not None, "read before open"
        return self.renderer.render(count, float(self.azimuth()))
