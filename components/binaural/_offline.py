"""Offline rendering of a scene: talkers at positions in a room, heard by a chosen head that may turn.

The API experiments use (numpy in, numpy out, no I/O)::

    from aiogenomix.components.binaural import Pose, Shoebox, Talker, render_scene, snowman_hrirs, speech_like

    rate = 44_100
    room = Shoebox.with_rt60((6.0, 4.0, 3.0), 0.5)
    listener = Pose(3.0, 2.0, 1.5, facing=0.0)
    rng = np.random.default_rng(1)
    talkers = [Talker(speech_like(3.0, rate, rng), listener.at(30.0, distance=1.5)),
               Talker(speech_like(3.0, rate, rng, voice="female"), listener.at(-100.0, distance=2.0), level=-3.0)]
    ears = render_scene(talkers, listener, rate=rate, seconds=3.0, room=room,
                        head=lambda t: 20.0 * t,          # the head's room azimuth, degrees, at time t
                        hrirs=snowman_hrirs())            # a head the localiser's templates do not come from

``room_response`` gives a binaural room impulse response (the scene of one unit
impulse); ``Path`` moves a talker along waypoints at a speed.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

from ._errors import BinauralError
from ._geometry import Pose, Position
from ._hrir_set import HrirSet
from ._room import Shoebox
from ._room_renderer import RoomRenderer

__all__ = ["Talker", "Path", "render_scene", "room_response"]

#: A head's room azimuth: fixed (degrees), or a function of the time in seconds.
HeadMotion = float | Callable[[float], float] | None


@dataclasses.dataclass(frozen=True)
class Path:
    """Waypoints a talker walks through at a constant speed, then stays at the last (or starts again).

    Attributes:
        waypoints: Room-frame positions, metres (at least one).
        speed: Metres per second.
        loop: Go back to the first waypoint after the last, and on, instead of stopping.
    """

    waypoints: tuple[Position, ...]
    speed: float
    loop: bool = False

    def __post_init__(self) -> None:
        if not self.waypoints:
            raise BinauralError("a path needs at least one waypoint")
        if not (math.isfinite(self.speed) and self.speed > 0):
            raise BinauralError(f"a path's speed must be positive, not {self.speed!r}")

    def position(self, seconds: float) -> Position:
        """Where the walker is *seconds* after the start."""
        points = np.asarray(self.waypoints, dtype=np.float64)
        if self.loop and len(points) > 1:
            points = np.vstack([points, points[:1]])
        legs = np.linalg.norm(np.diff(points, axis=0), axis=1)
        total = float(legs.sum())
        travelled = seconds * self.speed
        if total == 0.0:
            return _point(points[0])
        travelled = travelled % total if self.loop else min(travelled, total)
        ends = np.cumsum(legs)
        leg = min(int(np.searchsorted(ends, travelled, side="right")), len(legs) - 1)
        into = travelled - (ends[leg] - legs[leg])
        share = into / legs[leg] if legs[leg] > 0 else 0.0
        return _point(points[leg] + (points[leg + 1] - points[leg]) * share)


def _point(values: npt.NDArray[np.float64]) -> Position:
    return (float(values[0]), float(values[1]), float(values[2]))


@dataclasses.dataclass(frozen=True, eq=False)
class Talker:
    """One source of a scene.

    Attributes:
        signal: Dry samples at the rendering rate, full scale 1: the level 1 m away.
        position: Room-frame position in metres, or a :class:`Path`.
        level: Gain in dB applied to *signal*.
        onset: Seconds of silence before the signal starts.
        loop: Play the signal again and again (else once, then silence).
    """

    signal: npt.NDArray[np.float64]
    position: Position | Path
    level: float = 0.0
    onset: float = 0.0
    loop: bool = False

    def where(self, seconds: float) -> Position:
        """The talker's position at *seconds*."""
        return self.position.position(seconds) if isinstance(self.position, Path) else self.position

    def samples(self, start: int, count: int, rate: float) -> npt.NDArray[np.float64]:
        """*count* dry samples from frame *start* of the scene, with the onset, the loop and the level."""
        out = np.zeros(count)
        onset = round(self.onset * rate)
        first = max(start, onset)
        if first >= start + count or len(self.signal) == 0:
            return out
        index = np.arange(first - onset, start + count - onset)
        if self.loop:
            out[first - start:] = self.signal[index % len(self.signal)]
        else:
            inside = index < len(self.signal)
            out[first - start:][inside] = self.signal[index[inside]]
        return np.asarray(out * 10.0 ** (self.level / 20.0))


def _head_at(head: HeadMotion, listener: Pose) -> Callable[[float], float]:
    if head is None:
        return lambda _t: listener.facing
    if callable(head):
        return head
    fixed = float(head)
    return lambda _t: fixed


def render_scene(talkers: Sequence[Talker], listener: Pose | Path, *, rate: float, seconds: float,
                 room: Shoebox | None = None, hrirs: HrirSet | None = None, head: HeadMotion = None,
                 max_order: int = 3, mixing_time: float | None = None, diffuse_level: float | None = None,
                 sensor_noise: float | None = None, seed: int = 0, block: int = 1024) -> npt.NDArray[np.float64]:
    """The two ear signals of *talkers* heard at *listener* in *room* (or the free field) through *hrirs*.

    Args:
        talkers: The sources.
        listener: The head's centre and facing (or a :class:`Path` its centre walks; it then faces
            where *head* says, 0° by default).
        rate: Sample rate in Hz.
        seconds: How long.
        room: The shoebox (None: the free field, direct sound only).
        hrirs: The head (default: the MIT KEMAR).
        head: The head's room azimuth in degrees: fixed, or a function of time in seconds, read at
            the end of every block and moving linearly between (default: the listener's facing).
        max_order: Highest order of image sources rendered as early reflections.
        mixing_time: Where the late tail takes over, seconds (None: from the room's geometry).
        diffuse_level: RMS of an independent diffuse noise field at the ears, dB re full scale.
        sensor_noise: RMS of independent noise at each ear, dB re full scale.
        seed: Seed of the tails and the noises.
        block: Frames per block: head and talkers move linearly within a block.

    Returns:
        ``(round(seconds · rate), 2)`` float samples, left then right.
    """
    frames = round(seconds * rate)
    if block < 1:
        raise BinauralError(f"block must be at least one frame, not {block}")
    renderer = RoomRenderer(rate, len(talkers), hrirs=hrirs, room=room, max_order=max_order,
                            mixing_time=mixing_time, diffuse_level=diffuse_level, sensor_noise=sensor_noise,
                            seed=seed)
    facing = listener if isinstance(listener, Pose) else Pose(*listener.position(0.0))
    heading = _head_at(head, facing)
    out = np.zeros((frames, 2))
    for start in range(0, frames, block):
        count = min(block, frames - start)
        end = (start + count) / rate
        centre = listener.position if isinstance(listener, Pose) else listener.position(end)
        dry = (np.stack([t.samples(start, count, rate) for t in talkers]) if talkers else np.zeros((0, count)))
        positions = [t.where(end) for t in talkers]
        out[start:start + count] = renderer.render(dry, heading(end), positions or None, centre)
    return out


def room_response(position: Position, listener: Pose, *, rate: float, seconds: float = 1.0,
                  room: Shoebox | None = None, hrirs: HrirSet | None = None, max_order: int = 3,
                  mixing_time: float | None = None, seed: int = 0) -> npt.NDArray[np.float64]:
    """The binaural room impulse response ``(frames, 2)`` from a source at *position* to *listener*'s ears.

    Its direct sound arrives after the distance over the speed of sound at 1/r (a unit
    source 1 m away), then the early reflections and the tail, as :func:`render_scene`
    renders them.
    """
    impulse = np.zeros(round(seconds * rate))
    if len(impulse):
        impulse[0] = 1.0
    return render_scene([Talker(impulse, position)], listener, rate=rate, seconds=seconds, room=room,
                        hrirs=hrirs, max_order=max_order, mixing_time=mixing_time, seed=seed, block=4096)
