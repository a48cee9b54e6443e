"""A shoebox room: its walls' absorption per octave band, Eyring's reverberation time, and its image sources.

The room is the box ``origin ≤ (x, y, z) ≤ origin + dimensions`` in the room frame
of :mod:`._geometry` (metres). Each of its six walls absorbs a share α of the
energy that meets it, per octave band (125 Hz to 8 kHz); a reflection keeps the
amplitude ``β = √(1 − α)``.

**Image sources** (Allen & Berkley, "Image method for efficiently simulating
small-room acoustics", JASA 65(4), 1979). Along each axis, the images of a
source at ``s`` in a room of length ``L`` sit at ``u·L + s`` for even ``u`` and at
``(u + 1)·L − s`` for odd ``u``: the path from image ``u`` meets the walls ``|u|``
times, ``⌈|u|/2⌉`` times the wall it first crosses (the far one for ``u > 0``) and
``⌊|u|/2⌋`` the other. An image's order is ``|u| + |v| + |w|``, its amplitude the
product of its walls' ``β``, one per meeting, over its distance in metres (a
source heard at unit amplitude 1 m away).

**Eyring's reverberation time** per band, for a mean absorption ``ᾱ = Σ Sᵢαᵢ / S``:
``T60 = 24 ln 10 · V / (−c · S · ln(1 − ᾱ))`` (0.161 V / (−S ln(1 − ᾱ)) at
c = 343 m/s; Eyring, JASA 1, 1930). A room given by its RT60 gets the uniform
absorption whose Eyring time it is. Air absorption is not modelled.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np
import numpy.typing as npt

from ._errors import BinauralError

__all__ = ["OCTAVE_BANDS", "WALLS", "Shoebox", "ImageSources", "image_sources", "band_weights",
           "SPEED_OF_SOUND"]

#: Centre frequencies of the octave bands of absorption and reverberation, Hz.
OCTAVE_BANDS = (125.0, 250.0, 500.0, 1000.0, 2000.0, 4000.0, 8000.0)
#: The walls in the order of :attr:`Shoebox.absorption`: the low and high x, y and z sides
#: (``floor`` is z low, ``ceiling`` z high).
WALLS = ("x_low", "x_high", "y_low", "y_high", "floor", "ceiling")
#: Metres per second (dry air at 20 °C).
SPEED_OF_SOUND = 343.0
_EYRING = 24.0 * math.log(10.0)   # 4 · ln(10⁶): a mean free path of 4V/S


def _bands(value: float | Sequence[float] | npt.NDArray[np.float64], what: str) -> npt.NDArray[np.float64]:
    """A value per octave band from one number or one per band."""
    array = np.atleast_1d(np.asarray(value, dtype=np.float64))
    if array.shape == (1,):
        array = np.repeat(array, len(OCTAVE_BANDS))
    if array.shape != (len(OCTAVE_BANDS),) or not np.all(np.isfinite(array)):
        raise BinauralError(f"{what} takes one number or one per octave band "
                            f"({', '.join(f'{b:g}' for b in OCTAVE_BANDS)} Hz), not {value!r}")
    return array


@dataclasses.dataclass(frozen=True, eq=False)
class Shoebox:
    """A rectangular room and how much its walls absorb.

    Build one with :meth:`with_absorption` or :meth:`with_rt60`.

    Attributes:
        dimensions: (length along x, along y, height), metres.
        absorption: ``(6, 7)`` energy absorption of each wall (:data:`WALLS`) per octave band
            (:data:`OCTAVE_BANDS`), each in (0, 1].
        origin: The room frame's coordinates of the corner at the low x, y and z.
        speed_of_sound: Metres per second.
    """

    dimensions: tuple[float, float, float]
    absorption: npt.NDArray[np.float64]
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    speed_of_sound: float = SPEED_OF_SOUND

    def __post_init__(self) -> None:
        if len(self.dimensions) != 3 or not all(math.isfinite(d) and d > 0 for d in self.dimensions):
            raise BinauralError(f"a room's dimensions are three positive lengths in metres, not {self.dimensions!r}")
        if len(self.origin) != 3 or not all(math.isfinite(o) for o in self.origin):
            raise BinauralError(f"a room's origin is three finite coordinates, not {self.origin!r}")
        if self.absorption.shape != (len(WALLS), len(OCTAVE_BANDS)):
            raise BinauralError(f"absorption is one row per wall and one column per band, not {self.absorption.shape}")
        if not np.all((self.absorption > 0) & (self.absorption <= 1)):
            raise BinauralError("every wall's absorption must be above 0 and at most 1 in every band")
        if not self.speed_of_sound > 0:
            raise BinauralError(f"the speed of sound must be positive, not {self.speed_of_sound}")
        self.absorption.setflags(write=False)

    @classmethod
    def with_absorption(cls, dimensions: Sequence[float],
                        absorption: float | Sequence[float] | npt.NDArray[np.float64]
                        | Mapping[str, float | Sequence[float]], *,
                        origin: Sequence[float] = (0.0, 0.0, 0.0),
                        speed_of_sound: float = SPEED_OF_SOUND) -> Shoebox:
        """A room whose walls absorb *absorption*.

        Args:
            dimensions: (x, y, z) lengths in metres.
            absorption: One number for every wall and band, one per band for every wall, or a
                mapping from wall names (:data:`WALLS`) to either; walls it leaves out take the
                ``"walls"`` entry if there is one.
            origin: Where the low corner is in the room frame.
            speed_of_sound: Metres per second.

        Raises:
            BinauralError: naming the value that cannot be used.
        """
        if isinstance(absorption, Mapping):
            unknown = set(absorption) - set(WALLS) - {"walls"}
            if unknown:
                raise BinauralError(f"unknown wall {sorted(unknown)[0]!r} (walls: {', '.join(WALLS)}, or 'walls')")
            default = absorption.get("walls")
            rows = []
            for wall in WALLS:
                value = absorption.get(wall, default)
                if value is None:
                    raise BinauralError(f"the absorption of wall {wall!r} is missing (or give 'walls' for the rest)")
                rows.append(_bands(value, f"the absorption of {wall}"))
            table = np.stack(rows)
        else:
            table = np.tile(_bands(absorption, "absorption"), (len(WALLS), 1))
        return cls(_triple(dimensions, "dimensions"), table, _triple(origin, "origin"), float(speed_of_sound))

    @classmethod
    def with_rt60(cls, dimensions: Sequence[float], rt60: float | Sequence[float], *,
                  origin: Sequence[float] = (0.0, 0.0, 0.0), speed_of_sound: float = SPEED_OF_SOUND) -> Shoebox:
        """A room whose walls all absorb alike, as much as gives Eyring's *rt60* (seconds, one or one per band).

        Raises:
            BinauralError: for a time that no absorption gives (at or below the room's free path's).
        """
        times = _bands(rt60, "rt60")
        if not np.all(times > 0):
            raise BinauralError(f"rt60 must be positive, not {rt60!r}")
        size = _triple(dimensions, "dimensions")
        volume, surface = _volume(size), _surface(size)
        alpha = 1.0 - np.exp(-_EYRING * volume / (speed_of_sound * surface * times))
        return cls.with_absorption(size, alpha, origin=origin, speed_of_sound=speed_of_sound)

    @property
    def volume(self) -> float:
        """Cubic metres."""
        return _volume(self.dimensions)

    @property
    def surface(self) -> float:
        """Square metres of walls, floor and ceiling."""
        return _surface(self.dimensions)

    def wall_areas(self) -> npt.NDArray[np.float64]:
        """Square metres of each wall, in the order of :data:`WALLS`."""
        lx, ly, lz = self.dimensions
        return np.array([ly * lz, ly * lz, lx * lz, lx * lz, lx * ly, lx * ly])

    def mean_absorption(self) -> npt.NDArray[np.float64]:
        """The area-weighted absorption per band."""
        areas = self.wall_areas()
        return np.asarray(areas @ self.absorption / areas.sum())

    def eyring_rt60(self) -> npt.NDArray[np.float64]:
        """Eyring's reverberation time per octave band, seconds."""
        alpha = np.minimum(self.mean_absorption(), 1.0 - 1e-12)
        return np.asarray(_EYRING * self.volume / (-self.speed_of_sound * self.surface * np.log1p(-alpha)))

    def contains(self, point: Sequence[float]) -> bool:
        """Whether *point* (room frame, metres) is inside the room."""
        return all(o <= p <= o + d for p, o, d in zip(point, self.origin, self.dimensions, strict=True))


def _triple(values: Sequence[float], what: str) -> tuple[float, float, float]:
    try:
        x, y, z = (float(v) for v in values)
    except (TypeError, ValueError):
        raise BinauralError(f"{what} are three numbers, not {values!r}") from None
    return (x, y, z)


def _volume(size: tuple[float, float, float]) -> float:
    return size[0] * size[1] * size[2]


def _surface(size: tuple[float, float, float]) -> float:
    return 2.0 * (size[0] * size[1] + size[0] * size[2] + size[1] * size[2])


@dataclasses.dataclass(frozen=True)
class ImageSources:
    """The image sources of one source in a room, as seen from one point.

    Attributes:
        positions: ``(n, 3)`` room-frame positions, metres; the first is the source itself.
        orders: ``(n,)`` reflections on the way.
        distances: ``(n,)`` metres to the listening point.
        gains: ``(n, 7)`` amplitude per octave band: the walls' ``β`` product over the distance.
    """

    positions: npt.NDArray[np.float64]
    orders: npt.NDArray[np.int64]
    distances: npt.NDArray[np.float64]
    gains: npt.NDArray[np.float64]

    def delays(self, speed_of_sound: float) -> npt.NDArray[np.float64]:
        """Seconds from the source to the listening point along each image's path."""
        return np.asarray(self.distances / speed_of_sound)


#: Nearer than this, a source's distance is taken as this (m): 1/r stays finite inside a head.
MIN_DISTANCE = 0.1


def image_sources(room: Shoebox, source: npt.ArrayLike, listener: npt.ArrayLike, *,
                  max_order: int | None = None, max_time: float | None = None) -> ImageSources:
    """The source and its images up to *max_order* reflections and *max_time* seconds of travel.

    Args:
        room: The room.
        source: Room-frame position of the source, metres (inside the room).
        listener: Room-frame position of the listening point, metres (inside the room).
        max_order: The most reflections (None: as many as *max_time* reaches).
        max_time: The longest travel in seconds (None: any, within *max_order*).

    Returns:
        The images sorted by distance, the source first.

    Raises:
        BinauralError: when both limits are None, or a point is outside the room.
    """
    if max_order is None and max_time is None:
        raise BinauralError("image sources need a highest order or a longest time")
    for name, point in (("source", np.asarray(source, dtype=np.float64)),
                        ("listener", np.asarray(listener, dtype=np.float64))):
        if point.shape != (3,) or not room.contains(point.tolist()):
            raise BinauralError(f"the {name} at {tuple(point.tolist())} is outside the room "
                                f"(from {room.origin} over {room.dimensions} m)")
    lengths = np.asarray(room.dimensions)
    local_source = np.asarray(source, dtype=np.float64) - room.origin
    local_listener = np.asarray(listener, dtype=np.float64) - room.origin
    reach = math.inf if max_time is None else max_time * room.speed_of_sound
    if max_order is None:
        max_order = int(math.ceil(reach / float(lengths.min()))) + 1
    span = np.arange(-max_order, max_order + 1)
    u, v, w = (a.ravel() for a in np.meshgrid(span, span, span, indexing="ij"))
    keep = np.abs(u) + np.abs(v) + np.abs(w) <= max_order
    indices = np.stack([u[keep], v[keep], w[keep]], axis=1)                             # (n, 3)
    odd = indices % 2 == 1
    local = np.where(odd, (indices + 1) * lengths - local_source, indices * lengths + local_source)
    distances = np.linalg.norm(local - local_listener, axis=1)
    near = distances <= reach
    indices, local, distances = indices[near], local[near], distances[near]
    # Meetings with each wall: the far wall (high side) first for u > 0, the near one for u < 0.
    magnitude = np.abs(indices)
    first, second = (magnitude + 1) // 2, magnitude // 2
    high = np.where(indices > 0, first, second)
    low = np.where(indices > 0, second, first)
    counts = np.empty((len(indices), len(WALLS)), dtype=np.int64)
    counts[:, 0::2], counts[:, 1::2] = low, high                                        # x_low, x_high, ...
    log_beta = 0.5 * np.log1p(-np.minimum(room.absorption, 1.0 - 1e-15))                 # (walls, bands)
    gains = np.exp(counts @ log_beta) / np.maximum(distances, MIN_DISTANCE)[:, np.newaxis]
    gains[counts @ (room.absorption >= 1.0 - 1e-15) > 0] = 0.0                           # a fully absorbing wall
    order = np.argsort(distances, kind="stable")
    return ImageSources(local[order] + room.origin, magnitude.sum(axis=1)[order], distances[order], gains[order])


def band_weights(frequencies: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Weights ``(7, len(frequencies))`` that split a spectrum into the octave bands and sum to 1.

    Between two neighbouring centres the lower band's weight falls as cos² and the upper's
    rises as sin² of (π/2 · octaves above the lower centre); below the first centre and above
    the last, the outer band takes everything.
    """
    f = np.maximum(np.asarray(frequencies, dtype=np.float64), 1e-3)
    centres = np.asarray(OCTAVE_BANDS)
    weights = np.zeros((len(centres), len(f)))
    weights[0, f <= centres[0]] = 1.0
    weights[-1, f >= centres[-1]] = 1.0
    for b in range(len(centres) - 1):
        inside = (f > centres[b]) & (f < centres[b + 1])
        phase = 0.5 * np.pi * np.log2(f[inside] / centres[b])
        weights[b, inside] = np.cos(phase) ** 2
        weights[b + 1, inside] = np.sin(phase) ** 2
    return weights
