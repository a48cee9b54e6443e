"""What a port's data says, read once for every tool that shows it: its capture time, the head, odometry, audio chunks.

The recording writes ROS messages and the Foxglove view writes Foxglove's, but both must agree
on what the data means: when it was captured, the head's azimuth in radians, the robot's
velocity in its own frame, how many frames each chunk of an audio read holds.  Those readings
live here, once.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any, Literal

__all__ = [
    "AUDIO_TYPES", "seconds_of", "stamp_of", "number", "HeadState", "head_state", "PlanarOdometry", "planar_odometry",
    "frames_per_chunk",
]

#: The audio ports: their IDL type and whether their index counts chunks (capture) or frames (bass).
AUDIO_TYPES: dict[str, Literal["chunks", "frames"]] = {
    "::capture::port_t": "chunks", "::kemarcapture::port_t": "chunks", "::binaudio::portStruct": "frames"}


def seconds_of(stamp: Any) -> float | None:
    """POSIX seconds of a port's timestamp struct (``{tv_sec, tv_nsec}``), or None when it is not one (or zero)."""
    if isinstance(stamp, Mapping) and "tv_sec" in stamp:
        seconds = float(stamp["tv_sec"]) + float(stamp.get("tv_nsec", 0)) * 1e-9
        return seconds if seconds > 0 else None
    return None


def stamp_of(data: Any) -> float | None:
    """The capture time a port's data carries: a ``timestamp``, ``stamp`` or ``ts`` member, or its header's stamp."""
    if not isinstance(data, Mapping):
        return None
    for key in ("timestamp", "stamp", "ts"):
        seconds = seconds_of(data.get(key))
        if seconds is not None:
            return seconds
    header = data.get("header")
    if isinstance(header, Mapping):
        return seconds_of(header.get("stamp"))
    return None


def number(value: Any) -> float:
    """A number of JSON data, where ``null`` stands for NaN (JSON has no NaN)."""
    return math.nan if value is None else float(value)


@dataclasses.dataclass(frozen=True)
class HeadState:
    """The KEMAR head's state as robotics tools want it.

    Attributes:
        position: Azimuth in radians, positive to the left (the port says degrees).
        velocity: Radians per second (the port's ``speed`` says degrees per second).
    """

    position: float
    velocity: float


def head_state(data: Mapping[str, Any]) -> HeadState:
    """The head's state of a ``::kemar::state`` publication (as JSON), in radians."""
    return HeadState(math.radians(number(data.get("position"))), math.radians(number(data.get("speed"))))


@dataclasses.dataclass(frozen=True)
class PlanarOdometry:
    """A robot's pose in the room and its velocity in its own frame, as ROS and Foxglove define odometry.

    Attributes:
        x: Metres, room frame.
        y: Metres, room frame.
        yaw: Heading in radians, counter-clockwise from the room's x axis.
        forward: Velocity along the robot's x axis (ahead), m/s.
        leftward: Velocity along the robot's y axis (to its left), m/s.
        turn: Yaw rate, rad/s.
    """

    x: float
    y: float
    yaw: float
    forward: float
    leftward: float
    turn: float

    @property
    def orientation(self) -> tuple[float, float, float, float]:
        """The heading as a quaternion ``(x, y, z, w)`` about the vertical axis."""
        return 0.0, 0.0, math.sin(self.yaw / 2), math.cos(self.yaw / 2)


def planar_odometry(data: Mapping[str, Any]) -> PlanarOdometry:
    """The odometry of a ``::world::odometry`` publication (as JSON): the room's velocity turned into the robot's.

    The port gives ``vx``, ``vy`` in the room's frame; ``nav_msgs/Odometry`` and ``foxglove.Odometry``
    carry the twist in the robot's (``child_frame_id``, ``body_frame_id``).
    """
    yaw = number(data.get("w"))
    cos, sin = math.cos(yaw), math.sin(yaw)
    vx, vy = number(data.get("vx")), number(data.get("vy"))
    return PlanarOdometry(x=number(data.get("x")), y=number(data.get("y")), yaw=yaw, forward=cos * vx + sin * vy,
                          leftward=-sin * vx + cos * vy, turn=number(data.get("vw")))


def frames_per_chunk(frames: int, chunks: int) -> int:
    """The frames of each chunk of a read of *chunks* whole chunks holding *frames* frames.

    Raises:
        ValueError: when *frames* is not a whole number of *chunks* chunks (the read is not the one asked).
    """
    if chunks <= 0 or frames % chunks:
        raise ValueError(f"{frames} frames are not {chunks} whole chunks")
    return frames // chunks
