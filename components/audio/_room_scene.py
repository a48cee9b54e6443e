"""Scenes in metres: a shoebox room, a listener, sources at positions or on paths, WAV talkers and any head.

A scene is in metres when it has a ``room`` or a ``listener``, or a source with a
``position``, ``distance``, ``elevation`` or ``path`` (:attr:`Scene.placed`). It then
renders through :class:`~aiogenomix.components.binaural.RoomRenderer`::

    "room": {
      "dimensions": [6, 4, 3],          # metres along x, y and z
      "origin": [0, 0, 0],              # the room frame's coordinates of its low corner
      "rt60": 0.5,                      # seconds (Eyring), one or one per octave band 125 Hz-8 kHz, or:
      "absorption": 0.2,                # every wall, one or one per band, or per wall:
                                        # {"floor": 0.1, "ceiling": [0.6, ...], "walls": 0.05}
      "max_order": 3,                   # image sources up to this order
      "mixing_time": null               # seconds where the late tail takes over (null: from the geometry)
    },
    "listener": {"x": 3, "y": 2, "z": 1.5, "facing": 0}

A measured room is ``"room": {"sofa": "hall.sofa"}``: binaural room impulse responses with head
orientations (SOFA ``MultiSpeakerBRIR``, ``SingleRoomMIMOSRIR`` or ``SingleRoomSRIR``), each source at
one of its loudspeakers (``"emitter": 0``); they include the head that measured them.

The listener is where the head is when no robot says (``kemar`` and its captures
hear from there; ``morse_kemar`` and ``pr2`` say where their head is in the virtual
world), and its ``facing`` adds to the head's azimuth. Without one, the head is at
the room's centre (1.5 m up, or half its height if lower), else at the origin.
"""

from __future__ import annotations

import functools
import math
import os
from collections.abc import Mapping, Sequence
from fractions import Fraction
from typing import Any

import numpy as np
import numpy.typing as npt

from ..binaural import (
    BinauralError, HrirSet, MeasuredRoomRenderer, Path, Pose, RoomRenderer, Shoebox, load_kemar, read_sofa,
    read_sofa_room, snowman_hrirs,
)
from ._errors import SceneError
from ._head_model import to_int32
from ._paths import confined_path, open_regular_file
from ._scene import Scene, Source, SourceSignal

__all__ = ["RoomSceneRenderer", "MeasuredSceneRenderer", "check_placed", "shoebox_of", "listener_of", "scene_hrirs",
           "read_wav", "measured"]

#: The largest WAV file a source reads (bytes): ten minutes of stereo float at 96 kHz.
MAX_WAV_BYTES = 512 << 20
_ROOM_KEYS = {"dimensions", "origin", "rt60", "absorption", "max_order", "mixing_time", "sofa"}
_LISTENER_KEYS = {"x", "y", "z", "facing"}
#: The diffuse field and the sensor noise draw from their own seed, apart from the sources'.
_NOISE_SEED_OFFSET = 1_000_003


def _number(value: object, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise SceneError(f"{what} must be a finite number, not {value!r}")
    return float(value)


def _point(value: object, what: str) -> tuple[float, float, float]:
    if not isinstance(value, Sequence) or isinstance(value, str) or len(value) != 3:
        raise SceneError(f"{what} is [x, y, z] in metres, not {value!r}")
    x, y, z = (_number(v, what) for v in value)
    return (x, y, z)


def shoebox_of(room: Mapping[str, Any], speed_of_sound: float = 343.0) -> Shoebox:
    """The :class:`Shoebox` a scene's ``room`` describes.

    Raises:
        SceneError: naming the key or value that cannot be used.
    """
    if not isinstance(room, Mapping):
        raise SceneError("room is an object: {\"dimensions\": [x, y, z], \"rt60\": seconds}")
    unknown = set(room) - _ROOM_KEYS
    if unknown:
        raise SceneError(f"unknown room key {sorted(unknown)[0]!r} (keys: {', '.join(sorted(_ROOM_KEYS))})")
    if "sofa" in room:
        raise SceneError("a measured room ({\"sofa\": FILE}) is no shoebox")
    if ("rt60" in room) == ("absorption" in room):
        raise SceneError("a room has its walls' absorption or its rt60: one of the two")
    dimensions = _point(room.get("dimensions"), "room.dimensions")
    origin = _point(room.get("origin", (0.0, 0.0, 0.0)), "room.origin")
    try:
        if "rt60" in room:
            return Shoebox.with_rt60(dimensions, room["rt60"], origin=origin, speed_of_sound=speed_of_sound)
        return Shoebox.with_absorption(dimensions, room["absorption"], origin=origin, speed_of_sound=speed_of_sound)
    except (BinauralError, TypeError, ValueError) as exc:
        raise SceneError(f"room: {exc}") from None


def measured(scene: Scene) -> bool:
    """Whether the scene's room is a measured one (``{"sofa": FILE}``)."""
    return isinstance(scene.room, Mapping) and "sofa" in scene.room


def listener_of(scene: Scene) -> Pose:
    """Where the scene's head is when no robot says, and where it faces."""
    raw = scene.listener
    if raw is None:
        if scene.room is None or measured(scene):
            return Pose(0.0, 0.0, 1.5)
        room = shoebox_of(scene.room)
        (x, y, z), (lx, ly, lz) = room.origin, room.dimensions
        return Pose(x + lx / 2, y + ly / 2, z + min(1.5, lz / 2))
    if not isinstance(raw, Mapping) or set(raw) - _LISTENER_KEYS:
        raise SceneError(f"listener is {{\"x\": m, \"y\": m, \"z\": m, \"facing\": degrees}}, not {raw!r}")
    values = {key: _number(raw.get(key, default), f"listener.{key}")
              for key, default in (("x", 0.0), ("y", 0.0), ("z", 1.5), ("facing", 0.0))}
    return Pose(**values)


def _path_of(raw: object, what: str) -> Path:
    if not isinstance(raw, Mapping) or set(raw) - {"waypoints", "speed", "loop"}:
        raise SceneError(f"{what} is {{\"waypoints\": [[x, y, z], ...], \"speed\": m/s, \"loop\": false}}")
    points = raw.get("waypoints")
    if not isinstance(points, Sequence) or not points or len(points) > 1000:
        raise SceneError(f"{what}.waypoints is a list of 1 to 1000 points")
    loop = raw.get("loop", False)
    if not isinstance(loop, bool):
        raise SceneError(f"{what}.loop is true or false")
    try:
        return Path(tuple(_point(p, f"{what}.waypoints") for p in points), _number(raw.get("speed"), f"{what}.speed"),
                    loop)
    except BinauralError as exc:
        raise SceneError(f"{what}: {exc}") from None


def _placement(source: Source, index: int, listener: Pose) -> tuple[float, float, float] | Path:
    """Where a source of a scene in metres is: a point or a path."""
    what = f"sources[{index}]"
    if source.emitter is not None:
        raise SceneError(f"{what}: an emitter is a loudspeaker of a measured room (\"room\": {{\"sofa\": FILE}})")
    given = [source.position is not None, source.path is not None, source.distance is not None]
    if sum(given) != 1:
        raise SceneError(f"{what}: in a scene in metres a source has one of position, path, or distance "
                         "(with azimuth and elevation)")
    if source.path is not None:
        return _path_of(source.path, f"{what}.path")
    if source.position is not None:
        return _point(source.position, f"{what}.position")
    distance = _number(source.distance, f"{what}.distance")
    if not distance > 0:
        raise SceneError(f"{what}.distance must be positive")
    return listener.at(source.azimuth, source.elevation, distance)


def check_placed(scene: Scene) -> None:
    """Refuse a scene in metres that cannot be rendered: a bad room, listener or placement, a source outside.

    Raises:
        SceneError: naming what is wrong.
    """
    if scene.head == "spherical":
        raise SceneError("the spherical head renders azimuths only: a scene in metres needs HRIRs "
                         "(head \"kemar\" or \"snowman\", or an hrtf file)")
    if measured(scene):
        _check_measured(scene)
        return
    room = shoebox_of(scene.room, scene.speed_of_sound) if scene.room is not None else None
    listener = listener_of(scene)
    if room is not None:
        raw = scene.room or {}
        order = raw.get("max_order", 3)
        if isinstance(order, bool) or not isinstance(order, int) or not 0 <= order <= 10:
            raise SceneError("room.max_order is a whole number from 0 to 10")
        mixing = raw.get("mixing_time")
        if mixing is not None and not 0.02 <= _number(mixing, "room.mixing_time") <= 0.25:
            raise SceneError("room.mixing_time is within 0.02 and 0.25 s, or null")
        if not room.contains(listener.position):
            raise SceneError(f"the listener at {listener.position} is outside the room")
    for i, source in enumerate(scene.sources):
        place = _placement(source, i, listener)
        points = place.waypoints if isinstance(place, Path) else (place,)
        if room is not None and not all(room.contains(p) for p in points):
            raise SceneError(f"sources[{i}] is (or goes) outside the room")


def _check_measured(scene: Scene) -> None:
    raw = scene.room or {}
    if set(raw) != {"sofa"} or not isinstance(raw["sofa"], str):
        raise SceneError("a measured room is {\"sofa\": FILE} and nothing else")
    if scene.hrtf is not None or scene.head != "kemar" or scene.diffuse_level is not None:
        raise SceneError("a measured room is heard through the head that measured it, with its own noise: "
                         "no head, hrtf or diffuse_level")
    for i, source in enumerate(scene.sources):
        emitter = source.emitter
        if isinstance(emitter, bool) or not isinstance(emitter, int) or emitter < 0:
            raise SceneError(f"sources[{i}]: in a measured room a source plays from a loudspeaker: "
                             "\"emitter\": 0, 1, ...")
        if source.position is not None or source.path is not None or source.distance is not None:
            raise SceneError(f"sources[{i}]: in a measured room a source is at its emitter, not at a position")


def scene_hrirs(scene: Scene, roots: Sequence[str] | None) -> HrirSet:
    """The head a scene hears through: its ``hrtf`` file, else its ``head``'s HRIRs (blocks on the disk).

    Raises:
        SceneError: for an hrtf file that cannot be read as a head, or outside the allowed directories.
        BinauralError: when the KEMAR's HRIRs are unavailable.
    """
    if scene.hrtf is not None:
        path = confined_path(os.path.join(scene.base or "", scene.hrtf), roots)
        try:
            found = os.stat(path)
        except OSError as exc:
            raise SceneError(f"hrtf: cannot open {scene.hrtf!r}: {exc.strerror}") from None
        try:
            return _read_head(path, found.st_mtime_ns, found.st_size, scene.hrtf)
        except BinauralError as exc:
            raise SceneError(f"hrtf: {exc}") from None
    return snowman_hrirs() if scene.head == "snowman" else load_kemar()


@functools.lru_cache(maxsize=8)
def _read_head(path: str, modified: int, size: int, shown: str) -> HrirSet:
    """A SOFA head, read once per file version: the same set, so its filters (cached per set) are made once."""
    return read_sofa(path, shown=shown)


def read_wav(path: str, shown: str, rate: int) -> npt.NDArray[np.float64]:
    """A WAV file's samples at *rate*, its channels mixed (blocking: call it off the event loop).

    Raises:
        SceneError: for a file that is missing, not a regular file, too large or not audio soundfile reads.
    """
    import soundfile

    with open_regular_file(path, shown) as handle:
        if os.fstat(handle.fileno()).st_size > MAX_WAV_BYTES:
            raise SceneError(f"{shown!r} is larger than {MAX_WAV_BYTES >> 20} MiB")
        try:
            samples, native = soundfile.read(handle, dtype="float64", always_2d=True)
        except (RuntimeError, TypeError, ValueError, soundfile.LibsndfileError) as exc:
            raise SceneError(f"{shown!r} is not a sound file this scene reads: {exc}") from None
    mono = np.asarray(samples.mean(axis=1))
    if native != rate and len(mono):
        from scipy import signal

        ratio = Fraction(rate, int(native)).limit_denominator(20_000)
        mono = signal.resample_poly(mono, ratio.numerator, ratio.denominator)
    return mono


def _signals(scene: Scene, rate: int, roots: Sequence[str] | None) -> list[SourceSignal]:
    """The dry signals of the scene's sources, its WAV files read (blocking)."""
    signals = []
    for i, source in enumerate(scene.sources):
        samples = None
        if source.type == "file":
            assert source.file is not None
            path = confined_path(os.path.join(scene.base or "", source.file), roots)
            samples = read_wav(path, source.file, rate)
        signals.append(SourceSignal(source, rate, source.seed if source.seed is not None else scene.seed + i, samples))
    return signals


class MeasuredSceneRenderer:
    """Renders a scene in a measured room: each source through the BRIRs of its loudspeaker, the head turning.

    Args:
        scene: The scene (``"room": {"sofa": FILE}``).
        rate: Sample rate in Hz.
        roots: The directories its files may come from (None: anywhere).
    """

    def __init__(self, scene: Scene, rate: int, *, roots: Sequence[str] | None = None) -> None:
        self.scene = scene
        self.rate = rate
        self.facing = listener_of(scene).facing
        name = str((scene.room or {})["sofa"])
        try:
            room = read_sofa_room(confined_path(os.path.join(scene.base or "", name), roots), shown=name)
            self._signals = _signals(scene, rate, roots)
            self.renderer = MeasuredRoomRenderer(rate, room, [s.emitter or 0 for s in scene.sources],
                                                 sensor_noise=scene.noise_floor, seed=scene.seed + _NOISE_SEED_OFFSET)
        except BinauralError as exc:
            raise SceneError(f"room: {exc}") from None

    @property
    def frames_rendered(self) -> int:
        """Frames rendered so far."""
        return self.renderer.frames_rendered

    def render(self, count: int, head_azimuth: float, source_azimuths: npt.ArrayLike | None = None,
               listener: Sequence[float] | None = None) -> npt.NDArray[np.int32]:
        """The next *count* frames as S32 samples (azimuths and listener are the measurement's: ignored)."""
        return to_int32(self.render_float(count, head_azimuth, source_azimuths, listener))

    def render_float(self, count: int, head_azimuth: float, source_azimuths: npt.ArrayLike | None = None,
                     listener: Sequence[float] | None = None) -> npt.NDArray[np.float64]:
        """The next *count* frames with full scale 1, the head at *head_azimuth* (plus the listener's facing)."""
        dry = np.stack([s.next(count) for s in self._signals]) if self._signals else np.zeros((0, count))
        return self.renderer.render(dry, self.facing + head_azimuth)


class RoomSceneRenderer:
    """Renders a scene in metres: its sources at positions, in its room, at a head that may move and turn.

    Args:
        scene: The scene (:attr:`Scene.placed`).
        rate: Sample rate in Hz.
        roots: The directories its WAV and SOFA files may come from (None: anywhere).

    Building one reads the scene's files and tabulates the filters: do it off the event loop.
    """

    def __init__(self, scene: Scene, rate: int, *, roots: Sequence[str] | None = None) -> None:
        self.scene = scene
        self.rate = rate
        self.listener = listener_of(scene)
        hrirs = scene_hrirs(scene, roots)
        self._signals = _signals(scene, rate, roots)
        self._places = [_placement(s, i, self.listener) for i, s in enumerate(scene.sources)]
        diffuse = None
        if scene.diffuse_level is not None:
            power = sum(s.power(rate) for s in scene.sources)
            diffuse = 10.0 * math.log10(power) + scene.diffuse_level if power > 0 else None
        room = shoebox_of(scene.room, scene.speed_of_sound) if scene.room is not None else None
        raw = scene.room or {}
        self.renderer = RoomRenderer(rate, len(self._signals), hrirs=hrirs, room=room,
                                     max_order=int(raw.get("max_order", 3)), mixing_time=raw.get("mixing_time"),
                                     diffuse_level=diffuse, sensor_noise=scene.noise_floor,
                                     seed=scene.seed + _NOISE_SEED_OFFSET, speed_of_sound=scene.speed_of_sound)

    @property
    def frames_rendered(self) -> int:
        """Frames rendered so far."""
        return self.renderer.frames_rendered

    def positions(self, seconds: float) -> list[tuple[float, float, float]]:
        """The sources' positions *seconds* into the scene."""
        return [p.position(seconds) if isinstance(p, Path) else p for p in self._places]

    def render(self, count: int, head_azimuth: float, source_azimuths: npt.ArrayLike | None = None,
               listener: Sequence[float] | None = None) -> npt.NDArray[np.int32]:
        """The next *count* frames as S32 samples (the sources' azimuths are ignored: they have positions)."""
        return to_int32(self.render_float(count, head_azimuth, source_azimuths, listener))

    def render_float(self, count: int, head_azimuth: float, source_azimuths: npt.ArrayLike | None = None,
                     listener: Sequence[float] | None = None) -> npt.NDArray[np.float64]:
        """The next *count* frames with full scale 1.

        Args:
            count: Frames to render.
            head_azimuth: The head's azimuth at the end of these frames, added to the listener's facing.
            source_azimuths: Ignored (the sources are placed in metres).
            listener: Where the head's centre is at the end of these frames (None: the scene's listener).
        """
        end = (self.renderer.frames_rendered + count) / self.rate
        dry = np.stack([s.next(count) for s in self._signals]) if self._signals else np.zeros((0, count))
        centre = tuple(listener) if listener is not None else self.listener.position
        try:
            return self.renderer.render(dry, self.listener.facing + head_azimuth, self.positions(end) or None,
                                        centre)
        except BinauralError as exc:
            raise SceneError(f"the scene cannot be rendered: {exc}") from None
