"""The simulated binaural capture backend: a scene rendered at a spherical head, paced by the clock."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ..core import Clock
from ._backend import Azimuth, PacedBackend
from ._head_model import SphericalHeadRenderer
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

    Raises:
        SceneError: for a scene file that cannot be used.
    """

    kind = "simulated scene"

    def __init__(self, device: str, rate: int, frames_per_chunk: int, clock: Clock, *,
                 scene_file: str | None = None, scene: Scene | None = None,
                 azimuth: Azimuth | None = None) -> None:
        super().__init__(device, rate, frames_per_chunk, clock)
        if scene is None:
            scene = load_scene(scene_file) if scene_file else DEFAULT_SCENE
        self.scene = scene
        self.azimuth = azimuth or _facing_front
        self.renderer = SphericalHeadRenderer(scene, rate)

    def _produce(self, count: int) -> npt.NDArray[np.int32]:
        return self.renderer.render(count, float(self.azimuth()))
