"""A room's early reflections at the ears of a head that turns: image sources through their nearest measurements.

Each source's image sources (:func:`~._room.image_sources`, Allen & Berkley 1979) of
orders 1 to ``max_order`` that arrive before the mixing time are heard through the
measured response nearest their direction from the head (:class:`~._directions.NearestDirections`),
at their delay (rounded to a sample) and their walls' gain per octave band, faded out
(cos²) over the last few milliseconds before the mixing time. They make one response
per source and ear, whose spectrum the block convolution uses
(:class:`~._convolution.FadingConvolver`); when it changes, the output fades linearly
from the old response to the new across the block, so every sample is a convex mix of
two time-invariant convolutions: no click.

**What it costs.** The images depend on where the sources and the listener are, not
on where the head points: they are found once while nothing moves (:class:`_ImagePlan`).
A turning head changes the measurement an image is heard through only when it crosses
half the spacing of the measured directions; the responses are looked up at most every
``update`` seconds and made again only then. Making them is one weighted count
(``np.bincount``) of every image's taps into the responses of all sources and ears at
once, then one FFT: a fraction of a millisecond for three talkers at order 3, less than
changing only the images whose measurement changed, in the frequency domain (a head
turning 2.5° changes half of them). A room whose absorption differs per band would
need a response per band; the images' band gains of a source have few independent
shapes (one per order when the walls absorb alike), so it needs as many responses as
those, each heard through its mix of the band weights.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import numpy.typing as npt

from ._convolution import FadingConvolver
from ._directions import NearestDirections
from ._geometry import directions
from ._hrir_set import HrirSet
from ._room import Shoebox, band_weights, image_sources

__all__ = ["EarlyReflections"]


class EarlyReflections:
    """The early reflections of several sources in a room, streamed block after block.

    Args:
        room: The room.
        hrirs: The measured set, at the rendering rate.
        sources: How many sources.
        max_order: The highest order of the images heard.
        mixing_time: Seconds from a source's emission to the last image heard.
        fade: Seconds over which the images fade out before the mixing time.
        speed_of_sound: Metres per second.
        update: Frames between two look-ups of the images' measurements.

    Attributes:
        convolver: The block convolution of the sources into the ears (its ``taps`` and ``n_fft``).
        tail_head: Spectra ``(sources, 2, bins)`` added to the reflections' (the late tail's first taps).
    """

    def __init__(self, room: Shoebox, hrirs: HrirSet, sources: int, *, max_order: int, mixing_time: float,
                 fade: float, speed_of_sound: float, update: int) -> None:
        self.room = room
        self.rate = hrirs.rate
        self.sources = sources
        self.max_order = max_order
        self.mixing_time = mixing_time
        self.fade = fade
        self.speed_of_sound = speed_of_sound
        self.update = update
        # Reflections are heard through the first 6 ms of their responses (a head's response is that long;
        # the rest of a measured set's 512 taps is the measurement's low tail), faded out over the last 1 ms.
        kept = min(hrirs.length, round(0.006 * self.rate))
        taper = max(1, round(0.001 * self.rate))
        taps = hrirs.taps[:, :kept].copy()
        taps[:, kept - taper:] *= np.cos(0.5 * np.pi * np.arange(1, taper + 1) / taper)[:, np.newaxis]
        self._taps = np.ascontiguousarray(taps.transpose(0, 2, 1))                    # (directions, ears, taps)
        self._nearest = NearestDirections(hrirs)
        self.length = int(np.ceil(mixing_time * self.rate)) + kept
        self.convolver = FadingConvolver(sources, self.length)
        bins = self.convolver.n_fft // 2 + 1
        self.tail_head = np.zeros((sources, 2, bins), dtype=np.complex128)
        self._weights = band_weights(np.fft.rfftfreq(self.convolver.n_fft, 1.0 / self.rate))
        self._plan: _ImagePlan | None = None
        self._plan_keys: list[bytes] = []                                # per source: its position, the listener's
        self._plan_sources: list[_SourceImages] = []
        self._spectra: npt.NDArray[np.complex128] | None = None         # the responses' now
        self._made_with: tuple[_ImagePlan, npt.NDArray[np.intp]] | None = None
        self._since_update = 0

    def render(self, signals: npt.NDArray[np.float64], positions: npt.NDArray[np.float64],
               listener: npt.NDArray[np.float64], head: float) -> npt.NDArray[np.float64]:
        """The reflections ``(frames, 2)`` of the next frames of *signals* ``(sources, frames)``.

        The sources are at *positions* ``(sources, 3)``, the listener at *listener* and the head at room
        azimuth *head* (degrees) by the end of these frames; the responses fade to theirs across them when
        an update is due and they changed.
        """
        self._since_update += signals.shape[1]
        if self._spectra is None or self._since_update >= self.update:
            self._since_update = 0
            plan = self._image_plan(positions, listener)
            nearest = self._nearest_now(plan, head)
            # Only new images or an image heard through another measurement change the responses: a head
            # turning less than half a measurement's spacing (or still) costs the look-up alone.
            made = self._made_with
            if made is None or made[0] is not plan or not np.array_equal(made[1], nearest):
                previous, self._spectra = self._spectra, self._made(plan, nearest)
                self._made_with = (plan, nearest)
                if previous is not None:
                    return self.convolver.convolve(signals, previous, self._spectra)
        assert self._spectra is not None
        return self.convolver.convolve(signals, self._spectra)

    def spectra(self, positions: npt.NDArray[np.float64], listener: npt.NDArray[np.float64],
                head: float) -> npt.NDArray[np.complex128]:
        """The responses' spectra ``(sources, 2, bins)`` made afresh for these positions and head azimuth."""
        plan = self._image_plan(positions, listener)
        return self._made(plan, self._nearest_now(plan, head))

    def _image_plan(self, positions: npt.NDArray[np.float64], listener: npt.NDArray[np.float64]) -> _ImagePlan:
        """The reflected images of every source (kept while nothing moves; per source while one moves)."""
        keys = [position.tobytes() + listener.tobytes() for position in positions]
        if self._plan is not None and keys == self._plan_keys:
            return self._plan
        cached = dict(zip(self._plan_keys, self._plan_sources, strict=True))
        sources = [cached.get(key) or _SourceImages.of(self, position, listener)
                   for key, position in zip(keys, positions, strict=True)]
        self._plan_keys, self._plan_sources = keys, sources
        self._plan = _ImagePlan.of(sources, self.convolver.n_fft, self._taps.shape[2], self._weights)
        return self._plan

    def _nearest_now(self, plan: _ImagePlan, head: float) -> npt.NDArray[np.intp]:
        """The measured direction nearest each image's, seen from the head at room azimuth *head*."""
        return self._nearest.indices(plan.azimuth - head, plan.elevation)

    def _made(self, plan: _ImagePlan, nearest: npt.NDArray[np.intp]) -> npt.NDArray[np.complex128]:
        """The responses' spectra ``(sources, 2, bins)``, each image heard through its *nearest* measurement."""
        components, n_fft = plan.components.shape[0], self.convolver.n_fft
        weights = plan.components[:, :, np.newaxis, np.newaxis] * self._taps[nearest]     # (comp, images, ears, taps)
        # Counted straight into rows of the FFT's length: an FFT told to pad copies (a third of its time).
        responses = np.bincount(plan.index, weights.ravel(), minlength=components * self.sources * 2 * n_fft)
        spectra = np.fft.rfft(responses.reshape(components, self.sources, 2, n_fft), axis=-1)
        if plan.shapes is None:
            return np.asarray(spectra[0] + self.tail_head)
        made = self.tail_head.copy()
        for component in range(components):                # a sum of products: a third faster than einsum's
            made += spectra[component] * plan.shapes[:, component, np.newaxis]
        return made


def _fade_out(delays: npt.NDArray[np.float64], mixing: float, fade: float) -> npt.NDArray[np.float64]:
    """1 for images before the fade, falling as cos² to 0 at the mixing time."""
    share = np.clip((delays - (mixing - fade)) / fade, 0.0, 1.0)
    return np.asarray(np.cos(0.5 * np.pi * share))


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
    def of(cls, early: EarlyReflections, position: npt.NDArray[np.float64],
           listener: npt.NDArray[np.float64]) -> _SourceImages:
        """The images of a source at *position* heard at *listener* through *early*'s room."""
        images = image_sources(early.room, position, listener, max_order=early.max_order, max_time=early.mixing_time)
        reflected = images.orders > 0
        delays = images.delays(early.speed_of_sound)[reflected]
        gains = images.gains[reflected] * _fade_out(delays, early.mixing_time, early.fade)[:, np.newaxis]
        azimuth, elevation, _ = directions(images.positions[reflected], tuple(listener), 0.0)
        starts = np.round(delays * early.rate).astype(np.int64)
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
        components: ``(components, images)`` each image's weight in each response.
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
        """The plan of *sources*' images into rows of *length* samples, each image's response *taps* long."""
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
        components = np.zeros((width, images))
        shapes = None if flat else np.zeros((count, width, band_weights.shape[1]))
        owner = np.zeros(images, dtype=np.intp)
        at = 0
        for i, (source, (weights, mix)) in enumerate(zip(sources, factors, strict=True)):
            components[:weights.shape[1], at:at + len(source.starts)] = weights.T
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
