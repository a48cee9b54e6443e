"""Several sources at once: glimpses of every frame, placed in the room by the head's azimuth, explained by a mixture.

:class:`SourceLocaliser` streams like :class:`~._localiser.BinauralLocaliser`
(the same setup, noise learning and estimate every ``smoothing`` frames), but
each estimate names several sources: the frames' glimpses (:mod:`._glimpses`)
feed a :class:`~._mixture.RoomAzimuthFilter` with the head's azimuth at each
frame, whose peaks are the sources, seen from the head at the estimate's last
frame. A head that turns during an estimate is accounted for frame by frame.
The same glimpses can also feed a filter that outlives the estimates (what
``FaceSource`` and the head-movement strategies of :mod:`._head_movement` listen
with).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import numpy.typing as npt

from ._errors import LocalisationError
from ._glimpses import GlimpseAnalyser, GlimpseParameters, Glimpses
from ._hrir_set import HrirSet, wrap_degrees
from ._likelihood import GRID_DEGREES, _periodic_at, radians
from ._localiser import FrameAnalysis, LocaliserSetup, _Framer
from ._mixture import RoomAzimuthFilter, SourceAzimuth, SourceCounting

__all__ = ["SourceLocaliser", "SourcesEstimate"]


@dataclasses.dataclass(frozen=True)
class SourcesEstimate:
    """The sources of one estimate, seen from the head at its last frame.

    Attributes:
        sources: Strongest first; azimuths in degrees, head frame.
        distribution: ``(360,)`` the mixture's weight of each head-frame azimuth 0°, 1°, … (with
            :attr:`background`, they sum to 1).
        background: The weight of the diffuse background (reverberation, noise).
        frames: Analysis frames it rests on.
        end: Sample index (since the stream started) just after its last frame.
        head_azimuth: The head's room azimuth at the last frame, degrees (None when the audio carried none).
        requested: The number of sources asked for (None: counted).
        evidence: The share of what was heard that rose above the learnt noise (1 when none was learnt):
            under ``SourceCounting.min_evidence``, noise alone was heard and nothing is detected.
    """

    sources: tuple[SourceAzimuth, ...]
    distribution: npt.NDArray[np.float64]
    background: float
    frames: int
    end: int
    head_azimuth: float | None = None
    requested: int | None = None
    evidence: float = 1.0

    @property
    def azimuth(self) -> float:
        """The strongest source's azimuth, radians in (-π, π], head frame (NaN when none was found)."""
        return radians(self.sources[0].azimuth) if self.sources else math.nan

    @property
    def confidence(self) -> float:
        """The strongest source's confidence (0 when none was found)."""
        return self.sources[0].confidence if self.sources else 0.0

    def room_sources(self) -> tuple[SourceAzimuth, ...] | None:
        """The sources at their room azimuths (None when the head azimuth is unknown)."""
        if self.head_azimuth is None:
            return None
        return tuple(dataclasses.replace(s, azimuth=float(wrap_degrees(s.azimuth + self.head_azimuth)))
                     for s in self.sources)


class SourceLocaliser(FrameAnalysis):
    """Estimates the azimuths of several sources from two ear signals, in reverberation, with a turning head.

    Args:
        setup: The analysis parameters (those of ``binauloc``'s Setup).
        hrirs: The measured set the templates come from (default: the MIT KEMAR set).
        parameters: How glimpses are judged and weighed.
        counting: How sources are counted when their number is not given.

    :meth:`localise` makes one estimate of a block; :meth:`feed` streams, an estimate every
    ``setup.smoothing`` frames. :meth:`glimpses` gives the evidence of a block, for a filter
    of one's own.
    """

    def __init__(self, setup: LocaliserSetup | None = None, *, hrirs: HrirSet | None = None,
                 parameters: GlimpseParameters = GlimpseParameters(),
                 counting: SourceCounting = SourceCounting()) -> None:
        super().__init__(setup, hrirs=hrirs)
        self.analyser = GlimpseAnalyser(self.measured, self.setup.frame, self._bins, parameters)
        self.counting = counting
        self.reset_stream()

    def _noise_power(self) -> npt.NDArray[np.float64] | None:
        """The learnt noise's power per bin, both ears summed (None before any is learnt)."""
        if self._noise is None:
            return None
        return np.asarray((self._noise.r11 + self._noise.r22) / self._noise.frames)

    def reset_stream(self) -> None:
        """Start a new stream: forget the samples and frames fed since the last estimate (after a gap)."""
        self._framer = _Framer(self.setup.frame, self.setup.hop)
        self._consumed = 0
        self.analyser.reset()
        self._filter = self._new_filter()
        self._last_head: float | None = None
        self._headless = False

    def _new_filter(self) -> RoomAzimuthFilter:
        return RoomAzimuthFilter(capacity=max(self.setup.smoothing, 1), counting=self.counting)

    def glimpses(self, audio: npt.ArrayLike) -> tuple[Glimpses, npt.NDArray[np.intp]]:
        """The glimpses of every full frame of a block (a stream of its own), and each frame's centre sample.

        Raises:
            LocalisationError: when the block holds no full frame.
        """
        samples = self._checked(audio)
        frame, hop = self.setup.frame, self.setup.hop
        count = 0 if len(samples) < frame else (len(samples) - frame) // hop + 1
        if count == 0:
            raise LocalisationError(f"an estimate needs at least one frame of {frame} samples")
        self.analyser.reset()
        pieces = [self.analyser.analyse(self._spectra(samples[start * hop:(start + take - 1) * hop + frame]),
                                        self._noise_power())
                  for start in range(0, count, self.batch) for take in [min(self.batch, count - start)]]
        self.analyser.reset()
        reliable = [p.reliability for p in pieces if p.reliability is not None]
        noise = [p.noise_weight for p in pieces if p.noise_weight is not None]
        glimpses = Glimpses(np.concatenate([p.log_likelihood for p in pieces]),
                            np.concatenate([p.weight for p in pieces]), np.concatenate([p.power for p in pieces]),
                            np.concatenate(reliable) if len(reliable) == len(pieces) else None,
                            np.concatenate(noise) if len(noise) == len(pieces) else None)
        return glimpses, np.arange(count) * hop + frame // 2

    def localise(self, audio: npt.ArrayLike, heads: npt.ArrayLike | None = None,
                 count: int | None = None) -> SourcesEstimate:
        """One estimate from a block of audio (every full frame in it).

        Args:
            audio: ``(frames, 2)`` samples, left then right.
            heads: The head's room azimuth at each sample, degrees (None: unknown, the head frame).
            count: How many sources (None: counted).

        Raises:
            LocalisationError: when the block holds no full frame.
        """
        samples = self._checked(audio)
        glimpses, centres = self.glimpses(samples)
        frame_heads = np.zeros(len(centres)) if heads is None else \
            np.asarray(heads, dtype=np.float64).reshape(len(samples))[centres]
        room = RoomAzimuthFilter(capacity=glimpses.frames, counting=self.counting)
        room.add(glimpses, frame_heads)
        end = (glimpses.frames - 1) * self.setup.hop + self.setup.frame
        return self._estimate(room, end, None if heads is None else float(frame_heads[-1]), count)

    def feed(self, audio: npt.ArrayLike, heads: npt.ArrayLike | None = None, count: int | None = None,
             also: RoomAzimuthFilter | None = None) -> list[SourcesEstimate]:
        """Stream audio in; an estimate comes out every ``setup.smoothing`` frames.

        Args:
            audio: ``(frames, 2)`` samples following those fed before.
            heads: The head's room azimuth at each of these samples, degrees (from the positions
                carried with the audio), or None when unknown: the estimates are then in the head
                frame of a head taken as still.
            count: How many sources each estimate names (None: counted).
            also: A filter that every frame's glimpses feed too, with its head azimuth (frames whose
                head azimuth is unknown do not).

        Returns:
            The estimates completed by this audio, oldest first.
        """
        frame, hop, smoothing = self.setup.frame, self.setup.hop, self.setup.smoothing
        self._framer.add(self._checked(np.asarray(audio, dtype=np.float64).reshape(-1, 2)), heads)
        estimates = []
        while take := min(smoothing - self._filter.frames, self._framer.ready(), self.batch):
            samples, frame_heads = self._framer.take(take)
            glimpses = self.analyser.analyse(self._spectra(samples), self._noise_power())
            if frame_heads is None:
                self._headless = True
                frame_heads = np.zeros(take)
            elif also is not None:
                also.add(glimpses, frame_heads)
            if not self._headless:
                self._last_head = float(frame_heads[-1])
            self._filter.add(glimpses, 0.0 if self._headless else frame_heads)
            self._consumed += take * hop
            if self._filter.frames == smoothing:
                head = None if self._headless else self._last_head
                estimates.append(self._estimate(self._filter, self._consumed - hop + frame, head, count))
                self._filter = self._new_filter()
                self._headless = False
        return estimates

    def _estimate(self, room: RoomAzimuthFilter, end: int, head: float | None, count: int | None) -> SourcesEstimate:
        """The estimate of a filter's frames, seen from the head at *head* (None: the filter's frame is the head's)."""
        sources = room.sources(count)
        weights, background = room.distribution()
        seen_from = 0.0 if head is None else head
        in_head = tuple(dataclasses.replace(s, azimuth=float(wrap_degrees(s.azimuth - seen_from))) for s in sources)
        distribution = _periodic_at(weights, GRID_DEGREES + seen_from) if seen_from else weights
        return SourcesEstimate(in_head, distribution, background, room.frames, end, head, count, room.evidence)
