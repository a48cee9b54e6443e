"""Where things are in a room: positions in metres, a listener's pose, and directions seen from a head.

The room frame is the virtual world's: x and y on the floor, z up, in metres. An
azimuth is measured counter-clockwise from +x seen from above, so a positive azimuth
is to the LEFT of a listener facing 0°; an elevation is positive upwards. A head
facing ψ hears a source at room azimuth θ at head azimuth θ − ψ.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import numpy.typing as npt

from ._errors import BinauralError

__all__ = ["Pose", "Position", "directions", "position_at"]

#: A point in the room: (x, y, z) in metres.
Position = tuple[float, float, float]


@dataclasses.dataclass(frozen=True)
class Pose:
    """Where a listener's head is and which way it faces.

    Attributes:
        x: Metres.
        y: Metres.
        z: Height of the ears' axis, metres.
        facing: Room azimuth of the nose, degrees (positive = counter-clockwise from +x).
    """

    x: float = 0.0
    y: float = 0.0
    z: float = 1.5
    facing: float = 0.0

    def __post_init__(self) -> None:
        if not all(math.isfinite(v) for v in (self.x, self.y, self.z, self.facing)):
            raise BinauralError(f"a pose needs finite numbers, not {self}")

    @property
    def position(self) -> Position:
        """(x, y, z) in metres."""
        return (self.x, self.y, self.z)

    def turned(self, facing: float) -> Pose:
        """The same place, facing *facing* degrees."""
        return dataclasses.replace(self, facing=facing)

    def at(self, azimuth: float, elevation: float = 0.0, distance: float = 1.0) -> Position:
        """The point at *azimuth* (room frame), *elevation* (degrees) and *distance* (m) from the head."""
        return position_at(self.position, azimuth, elevation, distance)


def position_at(origin: Position, azimuth: float, elevation: float, distance: float) -> Position:
    """The point *distance* metres from *origin* in the direction (*azimuth*, *elevation*), degrees, room frame."""
    a, e = math.radians(azimuth), math.radians(elevation)
    return (origin[0] + distance * math.cos(e) * math.cos(a), origin[1] + distance * math.cos(e) * math.sin(a),
            origin[2] + distance * math.sin(e))


def directions(points: npt.ArrayLike, listener: Position,
               facing: float) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Head azimuths, elevations (degrees) and distances (m) of *points* seen from a head at *listener* facing *facing*.

    Args:
        points: ``(n, 3)`` positions in metres.
        listener: The centre of the head.
        facing: The head's room azimuth in degrees.

    Returns:
        ``(azimuth, elevation, distance)``, each ``(n,)``; azimuths wrapped to [-180, 180).
    """
    offset = np.atleast_2d(np.asarray(points, dtype=np.float64)) - np.asarray(listener, dtype=np.float64)
    horizontal = np.hypot(offset[:, 0], offset[:, 1])
    azimuth = np.degrees(np.arctan2(offset[:, 1], offset[:, 0])) - facing
    elevation = np.degrees(np.arctan2(offset[:, 2], horizontal))
    distance = np.sqrt(horizontal**2 + offset[:, 2] ** 2)
    return (azimuth + 180.0) % 360.0 - 180.0, elevation, distance
