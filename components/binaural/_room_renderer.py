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
2. **Early reflections.** The source's image sources (:func:`~._room.image_sources`,
   Allen & Berkley 1979) of orders 1 to ``max_order`` that arrive before the
   mixing time, each through the measured response nearest its direction from
   the head, at its delay (rounded to a sample) and its walls' gain per octave
   band. They make one response per source, made again (looked up at most every
   ``update`` seconds) when a source or the listener has moved or the head has
   turned far enough for an image to be heard through another measurement;
   the output fades linearly from the old response to the new across the
   block, so every sample is a convex mix of two time-invariant convolutions.
   All sources' images are made in one weighted count and one FFT, and a room
   whose absorption differs per band needs as many responses as its images'
   band gains have independent shapes (the number of orders when the walls
   absorb alike), not seven (:class:`_ImagePlan`).
3. **The late tail** from the mixing time on (:func:`~._late.late_tail`): the
   head's diffuse field decaying with the room's Eyring RT60 per band. It is
   fixed per source (that of the positions of the first block: a diffuse field
   does not turn with the head) and convolved in growing partitions.

The mixing time is, unless given, the arrival of the first image of order
``max_order + 1``: before it the images are complete, after it the tail takes
over (the early images fade out and the tail in over 5 ms, cos² and sin²).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import numpy.typing as npt

from ._convolution import FadingConvolver, StagedLateConvolver
from ._directions import NearestDirections
from ._errors import BinauralError
from ._filters import diffuse_filters
from ._geometry import Position, directions
from ._hrir_set import HrirSet, wrap_degrees
from ._kemar import load_kemar
from ._late import late_tail
from ._renderer import BinauralRenderer
from ._room import MIN_DISTANCE, SPEED_OF_SOUND, Shoebox, band_weights, image_sources

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
        update: Seconds between two makings of the early reflections while things move.
        diffuse_level: RMS of an independent diffuse noise field at the ears, dB re full scale, or None.
        sensor_noise: RMS of independent noise at each ear, dB re full scale, or None.
        seed: Seed of the tails, the diffuse field and the sensor noise.
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
        self._max_distance = (MAX_DISTANCE if room is None
                              else math.dist((0.0, 0.0, 0.0), room.dimensions) + MIN_DISTANCE)
        self._line_length = int(math.ceil(self._max_distance / self.speed_of_sound * self.rate)) + 4
        self._lines = np.zeros((sources, self._line_length))
        self._delays: npt.NDArray[np.float64] | None = None        # samples, at the end of the last block
        self._gains: npt.NDArray[np.float64] | None = None
        self._positions: npt.NDArray[np.float64] | None = None
        self._listener: npt.NDArray[np.float64] | None = None
        self._head: float | None = None
        self._nearest = NearestDirections(self.hrirs)
        self._early: FadingConvolver | None = None
        self._early_spectra: npt.NDArray[np.complex128] | None = None
        self._early_key: tuple[int, bytes] | None = None  # what they were made from: the plan's number, the nearest
        self._early_length = 0
        self._plan: _ImagePlan | None = None             # the images as the head looks them up: a turn keeps them
        self._plans = 0
        self._plan_keys: list[bytes] = []                # per source: its position and the listener's
        self._plan_sources: list[_SourceImages] = []
        self._since_update = 0
        self._late: StagedLateConvolver | None = None
        self._weights = np.ones((1, 1))                  # the octave bands' weights at the early FFT's bins
        self._reflection_taps = self.hrirs.taps
        self._reflection_taps_by_ear = np.zeros((0, 2, 0))   # the same as (directions, ears, taps)
        self._tail_head = np.zeros((0, 2, 1), dtype=np.complex128)
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
        edges = np.linspace(0, frames, pieces + 1).round().astype(int)
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
        for name, point in [("listener", listener)] + [(f"source {i}", p) for i, p in enumerate(positions)]:
            if not self.room.contains(point):
                raise BinauralError(f"the {name} at {tuple(np.round(point, 3))} m is outside the room "
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
            out += self._reflections(signals)
            assert self._late is not None
            out += self._late.convolve(signals)
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
        for source, (delay, gain) in enumerate(zip(delays, gains, strict=True)):
            where = self._line_length - float(delay)           # frame 0's place in the line, as in _delay
            base = math.floor(where)
            taps = _lagrange(np.asarray(where - base)) * gain
            first = base - 1                                    # taps at base - 1 ... base + 2, within the line
            row = line[source]
            out[source] = (taps[0] * row[first:first + frames] + taps[1] * row[first + 1:first + 1 + frames]
                           + taps[2] * row[first + 2:first + 2 + frames] + taps[3] * row[first + 3:first + 3 + frames])
        return out

    # -- the room ----------------------------------------------------------------------------------

    def _start_room(self, positions: npt.NDArray[np.float64], listener: npt.NDArray[np.float64]) -> None:
        """Fix the mixing time, make the early convolver and the tails, from the first block's positions."""
        assert self.room is not None
        room = self.room
        if self.mixing_time is None:
            firsts = [image_sources(room, p, listener, max_order=self.max_order + 1) for p in positions]
            arrivals = [float(np.min(s.distances[s.orders == self.max_order + 1])) for s in firsts]
            mixing = min(arrivals, default=_MIXING_BOUNDS[0] * self.speed_of_sound) / self.speed_of_sound
            self.mixing_time = float(np.clip(mixing, *_MIXING_BOUNDS))
        mixing_frames = int(math.ceil(self.mixing_time * self.rate))
        # Reflections are heard through the first 6 ms of their responses (a head's response is that long;
        # the rest of a measured set's 512 taps is the measurement's low tail), faded out over the last 1 ms.
        kept = min(self.hrirs.length, round(0.006 * self.rate))
        fade = max(1, round(0.001 * self.rate))
        self._reflection_taps = self.hrirs.taps[:, :kept].copy()
        self._reflection_taps[:, kept - fade:] *= np.cos(0.5 * np.pi * np.arange(1, fade + 1) / fade)[:, np.newaxis]
        self._reflection_taps_by_ear = np.ascontiguousarray(self._reflection_taps.transpose(0, 2, 1))
        self._early_length = mixing_frames + kept
        self._early = FadingConvolver(self.sources, self._early_length)
        rng = np.random.default_rng(self._seed + 17)
        diffuse = diffuse_filters(self._measured, self.rate)
        tails = [late_tail(diffuse, room.eyring_rt60(), volume=room.volume, speed_of_sound=self.speed_of_sound,
                           start=self.mixing_time, fade=_FADE, rng=rng) for _ in range(self.sources)]
        # The tail's first taps join the early responses (convolved at once, they need no latency); from the
        # largest power of two those hold on, the late convolver takes it in blocks that grow.
        block = 1 << int(math.floor(math.log2(self._early.taps)))
        length = max([len(t) for t in tails] + [block + 1])
        stacked = np.zeros((self.sources, length, 2))
        for i, tail in enumerate(tails):
            stacked[i, :len(tail)] = tail
        self._tail_head = self._early.spectra(stacked[:, :block])
        self._late = StagedLateConvolver(stacked, block)
        self._weights = band_weights(np.fft.rfftfreq(self._early.n_fft, 1.0 / self.rate))

    def _reflections(self, signals: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """The early reflections of these frames, fading to new responses when an image's response changed."""
        assert self._early is not None
        frames = signals.shape[1]
        self._since_update += frames
        if self._early_spectra is None or self._since_update >= self._update_frames:
            self._since_update = 0
            plan = self._image_plan()
            nearest = self._nearest_now(plan)
            key = (self._plans, nearest.tobytes())
            if key != self._early_key:
                # Only a new image set or an image heard through another measurement changes the responses:
                # a head turning less than half a measurement's spacing (or still) costs the look-up alone.
                spectra = self._early_spectra_of(plan, nearest)
                previous, self._early_spectra, self._early_key = self._early_spectra, spectra, key
                if previous is not None:
                    return self._early.convolve(signals, previous, spectra)
        assert self._early_spectra is not None
        return self._early.convolve(signals, self._early_spectra)

    def _early_filters(self) -> npt.NDArray[np.complex128]:
        """One making of the early reflections' spectra ``(sources, 2, bins)`` at the current positions and head."""
        plan = self._image_plan()
        return self._early_spectra_of(plan, self._nearest_now(plan))

    def _image_plan(self) -> _ImagePlan:
        """The reflected images of every source at the current positions (kept while nothing moves)."""
        assert self.room is not None and self._positions is not None and self._listener is not None
        assert self.mixing_time is not None
        keys = [position.tobytes() + self._listener.tobytes() for position in self._positions]
        if self._plan is not None and keys == self._plan_keys:
            return self._plan
        cached = dict(zip(self._plan_keys, self._plan_sources, strict=True))
        sources = [cached.get(key) or _SourceImages.of(self.room, position, self._listener, self)
                   for key, position in zip(keys, self._positions, strict=True)]
        self._plan_keys, self._plan_sources = keys, sources
        self._plans += 1
        self._plan = _ImagePlan.of(sources, self._early_length, self._reflection_taps.shape[1], self._weights)
        return self._plan

    def _nearest_now(self, plan: _ImagePlan) -> npt.NDArray[np.intp]:
        """The measured direction nearest each image's, seen from the head as it is now."""
        assert self._head is not None
        return self._nearest.indices(plan.azimuth - self._head, plan.elevation)

    def _early_spectra_of(self, plan: _ImagePlan, nearest: npt.NDArray[np.intp]) -> npt.NDArray[np.complex128]:
        """The early responses' spectra ``(sources, 2, bins)`` with each image heard through its *nearest* measurement.

        All sources, ears and band components are one weighted count (``np.bincount``) into one array of
        responses ``(components, sources, ears, taps)``, then one FFT.
        """
        assert self._early is not None
        components, sources, length = plan.components.shape[1], self.sources, self._early_length
        chosen = self._reflection_taps_by_ear[nearest]                                      # (images, ears, taps)
        weights = plan.components.T[:, :, np.newaxis, np.newaxis] * chosen                   # (comp, images, ...)
        responses = np.bincount(plan.index, weights.ravel(), minlength=components * sources * 2 * length)
        spectra = np.fft.rfft(responses.reshape(components, sources, 2, length), self._early.n_fft, axis=-1)
        if plan.shapes is None:
            result = spectra[0]
        else:
            result = np.einsum("csef,scf->sef", spectra, plan.shapes)
        return np.asarray(result + self._tail_head)


@dataclasses.dataclass(frozen=True, eq=False)
class _SourceImages:
    """One source's reflected images before the mixing time, as the head will look them up.

    Attributes:
        azimuth: ``(n,)`` room azimuths of the images from the listener, degrees.
        elevation: ``(n,)`` their elevations, degrees.
        starts: ``(n,)`` their delays in samples.
        gains: ``(n, bands)`` their amplitudes per octave band, faded out towards the mixing time.
    """

    azimuth: npt.NDArray[np.float64]
    elevation: npt.NDArray[np.float64]
    starts: npt.NDArray[np.int64]
    gains: npt.NDArray[np.float64]

    @classmethod
    def of(cls, room: Shoebox, position: npt.NDArray[np.float64], listener: npt.NDArray[np.float64],
           renderer: RoomRenderer) -> _SourceImages:
        assert renderer.mixing_time is not None
        images = image_sources(room, position, listener, max_order=renderer.max_order, max_time=renderer.mixing_time)
        reflected = images.orders > 0
        delays = images.delays(renderer.speed_of_sound)[reflected]
        gains = images.gains[reflected] * _fade_out(delays, renderer.mixing_time)[:, np.newaxis]   # (n, bands)
        azimuth, elevation, _ = directions(images.positions[reflected], tuple(listener), 0.0)
        starts = np.round(delays * renderer.rate).astype(np.int64)
        return cls(azimuth, elevation, starts, gains)


@dataclasses.dataclass(frozen=True, eq=False)
class _ImagePlan:
    """Every source's images, and how their responses are summed into one array of responses.

    The bands' gains of a source's images form a matrix ``(images, 7)`` whose rank is usually small: in a
    room whose walls absorb alike, an image's gains depend on its order only, so the rank is the number of
    orders. Its singular value decomposition ``U·Σ·Vᵀ`` makes the seven band responses from ``rank``
    responses (the columns of ``U·Σ``), each heard through the band mix ``Vᵀ`` of the band weights: the same
    spectra from fewer responses and FFTs. In a room that absorbs alike at every frequency, one response.

    Attributes:
        azimuth: ``(images,)`` room azimuths, all sources' images one after the other.
        elevation: ``(images,)`` elevations.
        components: ``(images, components)`` each image's weight in each response.
        shapes: ``(sources, components, bins)`` each response's spectral weighting (None: one response, unweighted).
        index: ``(components · images · ears · taps,)`` where each weighted tap goes in the responses.
    """

    azimuth: npt.NDArray[np.float64]
    elevation: npt.NDArray[np.float64]
    components: npt.NDArray[np.float64]
    shapes: npt.NDArray[np.float64] | None
    index: npt.NDArray[np.intp]

    @classmethod
    def of(cls, sources: list[_SourceImages], length: int, taps: int,
           band_weights: npt.NDArray[np.float64]) -> _ImagePlan:
        """The plan of *sources*' images into responses of *length* taps, each image's response *taps* long."""
        count = len(sources)
        flat = all(bool(np.all(s.gains == s.gains[:, :1])) for s in sources)
        factors: list[tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]] = []
        for source in sources:
            if flat or len(source.gains) == 0:
                factors.append((source.gains[:, :1], np.ones((1, source.gains.shape[1]))))
                continue
            u, sigma, vt = np.linalg.svd(source.gains, full_matrices=False)
            rank = max(1, int(np.sum(sigma > sigma[0] * 1e-12)))
            factors.append((u[:, :rank] * sigma[:rank], vt[:rank]))
        width = max((f[0].shape[1] for f in factors), default=1)
        images = sum(len(s.starts) for s in sources)
        components = np.zeros((images, width))
        shapes = None if flat else np.zeros((count, width, band_weights.shape[1]))
        owner = np.zeros(images, dtype=np.intp)
        at = 0
        for i, (source, (weights, mix)) in enumerate(zip(sources, factors, strict=True)):
            components[at:at + len(source.starts), :weights.shape[1]] = weights
            if shapes is not None:
                shapes[i, :mix.shape[0]] = mix @ band_weights
            owner[at:at + len(source.starts)] = i
            at += len(source.starts)
        starts = np.concatenate([s.starts for s in sources]) if sources else np.zeros(0, dtype=np.int64)
        # Tap t of image i's ear e in response c: at ((c · sources + owner) · 2 + e) · length + start + t.
        offset = (owner * 2 * length + starts)[:, np.newaxis, np.newaxis] + (np.arange(2) * length)[:, np.newaxis]
        index = (np.arange(width) * count * 2 * length)[:, np.newaxis, np.newaxis, np.newaxis] + (
            offset + np.arange(taps))[np.newaxis]
        return cls(np.concatenate([s.azimuth for s in sources]) if sources else np.zeros(0),
                   np.concatenate([s.elevation for s in sources]) if sources else np.zeros(0),
                   components, shapes, index.ravel())


def _fade_out(delays: npt.NDArray[np.float64], mixing: float) -> npt.NDArray[np.float64]:
    """1 for images before the fade, falling as cos² to 0 at the mixing time."""
    share = np.clip((delays - (mixing - _FADE)) / _FADE, 0.0, 1.0)
    return np.asarray(np.cos(0.5 * np.pi * share))


def _lagrange(fraction: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Cubic Lagrange weights ``(4, ...)`` of the samples at -1, 0, 1 and 2 around a *fraction* in [0, 1)."""
    d = fraction
    return np.stack([-d * (d - 1.0) * (d - 2.0) / 6.0, (d + 1.0) * (d - 1.0) * (d - 2.0) / 2.0,
                     -(d + 1.0) * d * (d - 2.0) / 2.0, (d + 1.0) * d * (d - 1.0) / 6.0])
