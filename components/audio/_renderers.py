"""The renderers of a simulated scene: the measured KEMAR head (the default) and the spherical head, by name.

Both turn a :class:`~._scene.Scene` into the two ear signals of a head that may
turn, block after block, from the same seeded dry signals, so that a capture and a
reference rendering of the same scene give identical samples.  Each block ends at
the head azimuth (and, for a listener moving through a room, the sources' azimuths)
given for it, moving linearly from those of the previous block: a turning head
gives no click.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Protocol

import numpy as np
import numpy.typing as npt

from ..binaural import BinauralRenderer, HrirSet, azimuth_filters, diffuse_filters, load_kemar
from ._head_model import SphericalHeadRenderer, to_int32
from ._scene import Scene, SourceSignal

__all__ = ["SceneRenderer", "KemarSceneRenderer", "scene_renderer", "prepare_kemar"]

#: The diffuse field and the sensor noise draw from their own seed, apart from the sources'.
_NOISE_SEED_OFFSET = 1_000_003


class SceneRenderer(Protocol):
    """What the simulated capture asks of a renderer."""

    @property
    def frames_rendered(self) -> int:
        """Frames rendered so far."""

    def render(self, count: int, head_azimuth: float, source_azimuths: npt.ArrayLike | None = None,
               listener: Sequence[float] | None = None) -> npt.NDArray[np.int32]:
        """The next *count* frames as S32 samples ``(count, 2)``, left then right.

        Args:
            count: Frames to render.
            head_azimuth: Head azimuth in the room at the end of these frames (degrees,
                positive to the left).
            source_azimuths: The sources' room azimuths at the end of these frames
                (None: as before; at first, the scene's). Scenes in metres ignore them.
            listener: The head's centre at the end of these frames, room frame, metres (None:
                the scene's listener). Only scenes in metres use it.
        """

    def render_float(self, count: int, head_azimuth: float, source_azimuths: npt.ArrayLike | None = None,
                     listener: Sequence[float] | None = None) -> npt.NDArray[np.float64]:
        """Like :meth:`render`, as float frames with full scale 1."""


class KemarSceneRenderer:
    """Renders a :class:`Scene` at the ears of a KEMAR through its measured HRIRs (Gardner & Martin 1995).

    Every source goes through the HRIRs interpolated at its direction relative to the
    head (:class:`~aiogenomix.components.binaural.BinauralRenderer`, resampled to any
    rate); the scene's diffuse field joins at ``diffuse_level`` relative to the sources'
    total dry power (its power at the ears against theirs before the HRIRs), and its
    ``noise_floor`` as independent noise at each ear.

    Args:
        scene: The sources and the noise.
        rate: Sample rate in Hz.
        hrirs: The measured set (default: the MIT KEMAR set).

    Building one resamples and tabulates the filters the first time a rate is used in a
    process (a few tenths of a second; the KEMAR set is read from its cache, or converted
    once per user): build it off the event loop.
    """

    def __init__(self, scene: Scene, rate: int, *, hrirs: HrirSet | None = None) -> None:
        self.scene = scene
        self.rate = rate
        self._signals = [SourceSignal(s, rate, s.seed if s.seed is not None else scene.seed + i)
                         for i, s in enumerate(scene.sources)]
        self._azimuths = np.array([s.azimuth for s in scene.sources], dtype=np.float64)
        diffuse = None
        if scene.diffuse_level is not None:
            power = sum(s.power(rate) for s in scene.sources)
            diffuse = 10.0 * math.log10(power) + scene.diffuse_level if power > 0 else None
        self.renderer = BinauralRenderer(rate, len(self._signals), hrirs=hrirs, diffuse_level=diffuse,
                                         sensor_noise=scene.noise_floor, seed=scene.seed + _NOISE_SEED_OFFSET)

    @property
    def frames_rendered(self) -> int:
        """Frames rendered so far."""
        return self.renderer.frames_rendered

    @property
    def head_azimuth(self) -> float | None:
        """The head azimuth at the end of the last block (None before the first)."""
        return self.renderer.head_azimuth

    def render(self, count: int, head_azimuth: float, source_azimuths: npt.ArrayLike | None = None,
               listener: Sequence[float] | None = None) -> npt.NDArray[np.int32]:
        """The next *count* frames as S32 samples (see :meth:`SceneRenderer.render`)."""
        return to_int32(self.render_float(count, head_azimuth, source_azimuths))

    def render_float(self, count: int, head_azimuth: float, source_azimuths: npt.ArrayLike | None = None,
                     listener: Sequence[float] | None = None) -> npt.NDArray[np.float64]:
        """The next *count* frames with full scale 1 (see :meth:`SceneRenderer.render`)."""
        if source_azimuths is not None:
            self._azimuths = np.asarray(source_azimuths, dtype=np.float64).reshape(len(self._signals))
        dry = (np.stack([s.next(count) for s in self._signals]) if self._signals else np.zeros((0, count)))
        return self.renderer.render(dry, head_azimuth, self._azimuths)


def scene_renderer(scene: Scene, rate: int, *, hrirs: HrirSet | None = None,
                   roots: Sequence[str] | None = None) -> SceneRenderer:
    """The renderer of a scene: in metres (:class:`RoomSceneRenderer`), else through HRIRs, else the sphere.

    Blocks on the disk (a scene's WAV and SOFA files) and tabulates filters: call it off the event loop.

    Args:
        scene: The scene.
        rate: Sample rate in Hz.
        hrirs: For a scene of azimuths, another set than the scene's head's (a test's).
        roots: The directories a scene's WAV and SOFA files may come from (None: anywhere).

    Raises:
        SceneError: for a scene file's WAV or SOFA file that cannot be used.
        BinauralError: when the KEMAR's HRIRs are unavailable.
    """
    if scene.head == "spherical":
        return SphericalHeadRenderer(scene, rate)
    if scene.placed:
        from ._room_scene import MeasuredSceneRenderer, RoomSceneRenderer, measured

        if measured(scene):
            return MeasuredSceneRenderer(scene, rate, roots=roots)
        return RoomSceneRenderer(scene, rate, roots=roots)
    if hrirs is None and (scene.hrtf is not None or scene.head != "kemar"):
        from ._room_scene import scene_hrirs

        hrirs = scene_hrirs(scene, roots)
    return KemarSceneRenderer(scene, rate, hrirs=hrirs)


def prepare_kemar(rate: int) -> None:
    """Tabulate the measured KEMAR's filters at *rate* now; they are kept for the process.

    A capture of ``sim`` at that rate then starts within a chunk instead of a tenth of a second
    later (the first use per user also converts the HRIRs: seconds). Blocks: call it off the event loop.

    Raises:
        BinauralError: when the HRIRs cannot be read.
    """
    hrirs = load_kemar()
    # The same arguments as BinauralRenderer's calls: the caches are keyed by them.
    azimuth_filters(hrirs, float(rate), 0.5)
    diffuse_filters(hrirs, float(rate))
