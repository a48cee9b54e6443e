"""The streaming room renderer: sources at positions in a shoebox room, heard by a head that moves and turns.

Each call renders the next block, ending at the listener's position and head
azimuth and the sources' positions given for it (they move linearly from the
previous block's). The ear signals add three parts:

1. **The direct sound.** Each source's dry signal goes through a delay line of
   its distance over the speed of sound (read at fractional positions by cubic
   Lagrange interpolation, so a moving source has its Doppler shift) at 1/r of
   its level (a source's level is its level 1 m away), then through the HRIRs
   of its direction relative to the head, interpolated in azimuth and between
   elevation rings, cross-faded from sub-block to sub-block
   (:class:`~._renderer.BinauralRenderer`): no click when the head turns.
2. **Early reflections** (:class:`~._early.EarlyReflections`). The source's
   image sources (Allen & Berkley 1979) of orders 1 to ``max_order`` that
   arrive before the mixing time, each through the measured response nearest
   its direction from the head, at its delay (rounded to a sample) and its
   walls' gain per octave band: one response per source, which changes (looked
   up at most every ``update`` seconds) when a source or the listener moves or
   the head turns far enough for an image to be heard through another
   measurement; the output fades linearly from the old response to the new
   across the block, so every sample is a convex mix of two time-invariant
   convolutions.
3. **The late tail** from the mixing time on (:func:`~._late.late_tail`): the
   head's diffuse field decaying with the room's Eyring RT60 per band. It is
   fixed (a diffuse field does not turn with the head), one for the room: the
   sources' dry signals are summed into it (decision 44: nothing in it depends
   on the source), convolved in growing partitions.

The mixing time is, unless given, the arrival of the first image of order
``max_order + 1``: before it the images are complete, after it the tail takes
over (the early images fade out and the tail in over 5 ms, cos² and sin²).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from ._convolution import StagedLateConvolver
from ._early import EarlyReflections
from ._errors import BinauralError
from ._filters import diffuse_filters
from ._geometry import Position, directions
from ._hrir_set import HrirSet, wrap_degrees
from ._kemar import load_kemar
from ._late import late_tail
from ._renderer import BinauralRenderer
from ._room import MIN_DISTANCE, SPEED_OF_SOUND, Shoebox, image_sources

__all__ = ["RoomRenderer"]

#: Seconds over which the early images fade out and the tail fades in.
_FADE = 0.005
#: The farthest a source may be heard from in the free field (m): the delay lines hold this much sound.
#: In a room, its diagonal.
MAX_DISTANCE = 100.0
#: The mixing time is kept within these bounds (s).
_MIXING_BOUNDS = (0.02, 0.25)


class RoomRenderer:
    """Renders sources at positions in a room (or in the free field) at the ears of a head that moves and turns.

    Args:
        rate: Sample rate in Hz (the HRIRs are resampled to it).
        sources: How many sources each block brings.
        hrirs: The head (default: the MIT KEMAR set).
        room: The room (None: the free field: direct sound only, with its delay and 1/r).
        max_order: The highest order of image sources heard as early reflections.
        mixing_time: Seconds from the source's emission where the late tail takes over (None: the
            arrival of the first image of order ``max_order + 1``, within 20 to 250 ms).
        update: Seconds between two look-ups of the early reflections' measurements (made again when one changed).
        diffuse_level: RMS of an independent diffuse noise field at the ears, dB re full scale, or None.
        sensor_noise: RMS of independent noise at each ear, dB re full scale, or None.
        seed: Seed of the tail, the diffuse field and the sensor noise.
        speed_of_sound: Metres per second (default: the room's, else 343).
    """

    def __init__(self, rate: float, sources: int, *, hrirs: HrirSet | None = None, room: Shoebox | None = None,
                 max_order: int = 3, mixing_time: float | None = None, update: float = 0.05,
                 diffuse_level: float | None = None, sensor_noise: float | None = None, seed: int = 0,
                 speed_of_sound: float | None = None) -> None:
        if max_order < 0:
            raise BinauralError(f"max_order must not be negative ({max_order})")
        if mixing_time is not None and not _MIXING_BOUNDS[0] <= mixing_time <= _MIXING_BOUNDS[1]:
            raise BinauralError(f"mixing_time must be within {_MIXING_BOUNDS[0]} and {_MIXING_BOUNDS[1]} s")
        measured = hrirs if hrirs is not None else load_kemar()
        self.rate = float(rate)
        self.sources = sources
        self.room = room
        self.max_order = max_order
        self.mixing_time = mixing_time
        self.speed_of_sound = float(speed_of_sound or (room.speed_of_sound if room is not None else SPEED_OF_SOUND))
        self.hrirs = measured.resampled(self.rate)
        self._measured = measured
        self.direct = BinauralRenderer(self.rate, sources, hrirs=measured, diffuse_level=diffuse_level,
                                       sensor_noise=sensor_noise, seed=seed)
        self._seed = seed
        self._update_frames = max(1, round(update * self.rate))
        self._room_bounds = ((np.asarray(room.origin), np.asarray(room.origin) + np.asarray(room.dimensions))
                             if room is not None else (np.zeros(3), np.zeros(3)))
        self._max_distance = (MAX_DISTANCE if room is None
                              else math.dist((0.0, 0.0, 0.0), room.dimensions) + MIN_DISTANCE)
        self._line_length = int(math.ceil(self._max_distance / self.speed_of_sound * self.rate)) + 4
        self._lines = np.zeros((sources, self._line_length))
        self._delays: npt.NDArray[np.float64] | None = None        # samples, at the end of the last block
        self._gains: npt.NDArray[np.float64] | None = None
        self._positions: npt.NDArray[np.float64] | None = None
        self._listener: npt.NDArray[np.float64] | None = None
        self._head: float | None = None
        self.early: EarlyReflections | None = None       # made with the first block's positions
        self._late: StagedLateConvolver | None = None
        self.frames_rendered = 0

    @property
    def head_azimuth(self) -> float | None:
        """The head's room azimuth at the end of the last block (None before the first)."""
        return self._head

    def render(self, dry: npt.ArrayLike, head_azimuth: float, positions: npt.ArrayLike | None = None,
               listener: Position | npt.ArrayLike | None = None) -> npt.NDArray[np.float64]:
        """Render the next block.

        Args:
            dry: ``(sources, frames)`` dry signals at their levels 1 m away (full scale 1).
            head_azimuth: The head's room azimuth at the end of the block, degrees, positive left.
            positions: ``(sources, 3)`` room-frame positions at the end of the block, metres
                (None: as before; required on the first call when there are sources).
            listener: The centre of the head at the end of the block, metres (None: as before;
                required on the first call).

        Returns:
            ``(frames, 2)`` float samples, left then right.
        """
        signals = np.asarray(dry, dtype=np.float64).reshape(self.sources, -1)
        frames = signals.shape[1]
        end_positions = (np.asarray(positions, dtype=np.float64).reshape(self.sources, 3) if positions is not None
                         else self._positions)
        end_listener = np.asarray(listener, dtype=np.float64).reshape(3) if listener is not None else self._listener
        if end_listener is None or (end_positions is None and self.sources):
            raise BinauralError("the first block needs the listener's and the sources' positions")
        if end_positions is None:
            end_positions = np.zeros((0, 3))
        self._check_inside(end_positions, end_listener)
        start_positions = self._positions if self._positions is not None else end_positions
        start_listener = self._listener if self._listener is not None else end_listener
        start_head = self._head if self._head is not None else float(head_azimuth)
        head_step = float(wrap_degrees(float(head_azimuth) - start_head))
        if self.room is not None and self._late is None:
            self._start_room(end_positions, end_listener)
        out = np.zeros((frames, 2))
        # Long blocks (a bass chunk of 170 ms) are rendered in pieces, each ending where the head and the
        # sources are by then, so that the reflections follow within a couple of update intervals.
        pieces = max(1, math.ceil(frames / (2 * self._update_frames)))
        edges = [0, frames] if pieces == 1 else np.linspace(0, frames, pieces + 1).round().astype(int).tolist()
        for first, last in zip(edges[:-1], edges[1:], strict=True):
            share = last / frames if frames else 1.0
            self._positions = start_positions + (end_positions - start_positions) * share
            self._listener = start_listener + (end_listener - start_listener) * share
            self._head = start_head + head_step * share
            out[first:last] = self._piece(signals[:, first:last])
        if frames == 0:
            self._positions, self._listener, self._head = end_positions, end_listener, start_head + head_step
        self.frames_rendered += frames
        return out

    def _check_inside(self, positions: npt.NDArray[np.float64], listener: npt.NDArray[np.float64]) -> None:
        if not (np.all(np.isfinite(positions)) and np.all(np.isfinite(listener))):
            raise BinauralError("positions must be finite numbers of metres")
        if self.room is None:
            return
        # Every point at once (room.contains point by point cost 2 % of a chunk's rendering); by name if not.
        low, high = self._room_bounds
        points = np.vstack([listener, positions])
        outside = np.flatnonzero(~np.all((points >= low) & (points <= high), axis=1))
        if len(outside):
            name = "listener" if outside[0] == 0 else f"source {outside[0] - 1}"
            raise BinauralError(f"the {name} at {tuple(np.round(points[outside[0]], 3))} m is outside the room "
                                f"(from {self.room.origin} over {self.room.dimensions} m)")

    def _piece(self, signals: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Render frames ending at the current positions and head azimuth."""
        assert self._positions is not None and self._listener is not None and self._head is not None
        listener = (float(self._listener[0]), float(self._listener[1]), float(self._listener[2]))
        azimuth, elevation, distance = directions(self._positions, listener, 0.0)
        delays = distance / self.speed_of_sound * self.rate
        gains = 1.0 / np.maximum(distance, MIN_DISTANCE)
        if np.any(distance > self._max_distance):
            raise BinauralError(f"a source is more than {self._max_distance:g} m from the listener")
        delayed = self._delay(signals, delays, gains)
        out = self.direct.render(delayed, self._head, azimuth, elevation)
        if self.room is not None:
            assert self.early is not None and self._late is not None
            out += self.early.render(signals, self._positions, self._listener, self._head)
            out += self._late.convolve(signals.sum(axis=0, keepdims=True))
        return out

    def _delay(self, signals: npt.NDArray[np.float64], delays: npt.NDArray[np.float64],
               gains: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """The signals through their delay lines, delay and gain moving linearly from the last block's."""
        frames = signals.shape[1]
        start_delays = self._delays if self._delays is not None else delays
        start_gains = self._gains if self._gains is not None else gains
        self._delays, self._gains = delays, gains
        line = np.concatenate([self._lines, signals], axis=1)
        self._lines = line[:, -self._line_length:]
        if frames == 0:
            return signals
        if np.array_equal(start_delays, delays) and np.array_equal(start_gains, gains) and np.all(delays >= 2.0):
            return self._delay_still(line, frames, delays, gains)
        ramp = np.arange(1, frames + 1) / frames
        delay = start_delays[:, np.newaxis] + (delays - start_delays)[:, np.newaxis] * ramp          # (src, frames)
        gain = start_gains[:, np.newaxis] + (gains - start_gains)[:, np.newaxis] * ramp
        # Sample j of this block sits at self._line_length + j in the line; read at that minus the delay.
        where = self._line_length + np.arange(frames) - delay
        base = np.floor(where).astype(np.int64)
        fraction = where - base
        taps = _lagrange(fraction)                                                                  # (4, src, frames)
        rows = np.arange(self.sources)[:, np.newaxis]
        out = sum(taps[k] * line[rows, np.clip(base + k - 1, 0, line.shape[1] - 1)] for k in range(4))
        return np.asarray(out * gain)

    def _delay_still(self, line: npt.NDArray[np.float64], frames: int, delays: npt.NDArray[np.float64],
                     gains: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """The last *frames* of the *line* through fixed delays (2 samples or more) and gains: four slices each."""
        out = np.empty((self.sources, frames))
        where = self._line_length - delays                      # frame 0's place in the line, as in _delay
        bases = np.floor(where)
        taps = _lagrange(where - bases) * gains                 # (4, sources)
        for source, base in enumerate(bases.astype(int).tolist()):
            first, row, tap = base - 1, line[source], taps[:, source]   # taps at base - 1 ... base + 2
            out[source] = (tap[0] * row[first:first + frames] + tap[1] * row[first + 1:first + 1 + frames]
                           + tap[2] * row[first + 2:first + 2 + frames] + tap[3] * row[first + 3:first + 3 + frames])
        return out

    # -- the room ----------------------------------------------------------------------------------

    def _start_room(self, positions: npt.NDArray[np.float64], listener: npt.NDArray[np.float64]) -> None:
        """Fix the mixing time, make the early reflections and the tail, from the first block's positions."""
        assert self.room is not None
        room = self.room
        if self.mixing_time is None:
            firsts = [image_sources(room, p, listener, max_order=self.max_order + 1) for p in positions]
            arrivals = [float(np.min(s.distances[s.orders == self.max_order + 1])) for s in firsts]
            mixing = min(arrivals, default=_MIXING_BOUNDS[0] * self.speed_of_sound) / self.speed_of_sound
            self.mixing_time = float(np.clip(mixing, *_MIXING_BOUNDS))
        self.early = EarlyReflections(room, self.hrirs, self.sources, max_order=self.max_order,
                                      mixing_time=self.mixing_time, fade=_FADE, speed_of_sound=self.speed_of_sound,
                                      update=self._update_frames)
        # One tail for every source (decision 44): their dry signals' sum goes through it, as a reverberator
        # fed by all the sources of a room; the first source's tail as it was when each had its own.
        rng = np.random.default_rng(self._seed + 17)
        tail = late_tail(diffuse_filters(self._measured, self.rate), room.eyring_rt60(), volume=room.volume,
                         speed_of_sound=self.speed_of_sound, start=self.mixing_time, fade=_FADE, rng=rng)
        # The tail's first taps join the early responses (convolved at once, they need no latency); from the
        # largest power of two those hold on, the late convolver takes it in blocks that grow.
        block = 1 << int(math.floor(math.log2(self.early.length)))
        stacked = np.zeros((1, max(len(tail), block + 1), 2))
        stacked[0, :len(tail)] = tail
        self.early.tail_head = np.repeat(self.early.convolver.spectra(stacked[:, :block]), self.sources, axis=0)
        self._late = StagedLateConvolver(stacked, block)


def _lagrange(fraction: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Cubic Lagrange weights ``(4, ...)`` of the samples at -1, 0, 1 and 2 around a *fraction* in [0, 1)."""
    d = fraction
    return np.stack([-d * (d - 1.0) * (d - 2.0) / 6.0, (d + 1.0) * (d - 1.0) * (d - 2.0) / 2.0,
                     -(d + 1.0) * d * (d - 2.0) / 2.0, (d + 1.0) * d * (d - 1.0) / 6.0])
