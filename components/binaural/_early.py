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
need a response per band; the images' band gains have few shapes (one per order when
the walls absorb alike), so it needs a response per shape, each heard through its mix
of the band weights, and each image is counted into one of them (:class:`_ImagePlan`).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import numpy.typing as npt
from scipy import fft

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
        # The plan, measurements and spectra of each response ``(components · sources, ears, bins)`` made last.
        self._made_with: tuple[_ImagePlan, npt.NDArray[np.intp], npt.NDArray[np.complex128]] | None = None
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
                before = made[1:] if made is not None and made[0] is plan else None
                previous = self._spectra
                self._spectra, rows = self._made(plan, nearest, before)
                self._made_with = (plan, nearest, rows)
                if previous is not None:
                    return self.convolver.convolve(signals, previous, self._spectra)
        assert self._spectra is not None
        return self.convolver.convolve(signals, self._spectra)

    def spectra(self, positions: npt.NDArray[np.float64], listener: npt.NDArray[np.float64],
                head: float) -> npt.NDArray[np.complex128]:
        """The responses' spectra ``(sources, 2, bins)`` made afresh for these positions and head azimuth."""
        plan = self._image_plan(positions, listener)
        return self._made(plan, self._nearest_now(plan, head))[0]

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

    def _made(self, plan: _ImagePlan, nearest: npt.NDArray[np.intp],
              before: tuple[npt.NDArray[np.intp], npt.NDArray[np.complex128]] | None = None
              ) -> tuple[npt.NDArray[np.complex128], npt.NDArray[np.complex128]]:
        """The responses' spectra ``(sources, 2, bins)``, each image heard through its *nearest* measurement.

        Also each response's spectra ``(components · sources, 2, bins)``, before their weighting. *before*: the
        measurements and those spectra last made with this plan, which are made again (in place) only for the
        responses of an image heard through another measurement (a turning head leaves a quarter of them).
        """
        components, n_fft = plan.components, self.convolver.n_fft
        weights = plan.weights[:, np.newaxis, np.newaxis] * self._taps[nearest[plan.images]]  # (entries, ears, taps)
        # Counted straight into rows of the FFT's length: an FFT told to pad copies (a third of its time).
        responses = np.bincount(plan.index, weights.ravel(), minlength=components * self.sources * 2 * n_fft)
        responses = responses.reshape(components * self.sources, 2, n_fft)
        if before is None:
            rows = fft.rfft(responses, axis=-1)               # scipy's: numpy's makes its plan every call
        else:
            rows = before[1]
            changed = np.unique(plan.rows[(nearest != before[0])[plan.images]])
            rows[changed] = fft.rfft(responses[changed], axis=-1)
        spectra = rows.reshape(components, self.sources, 2, -1)
        if plan.shapes is None:
            return np.asarray(spectra[0] + self.tail_head), rows
        made = self.tail_head.copy()
        for component in range(components):                # a sum of products: a third faster than einsum's
            made += spectra[component] * plan.shapes[:, component, np.newaxis]
        return made, rows


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


#: Two images' band gains have one shape when, each divided by its largest, they differ by at most this.
_SAME_SHAPE = 1e-12


@dataclasses.dataclass(frozen=True, eq=False)
class _ImagePlan:
    """Every source's images, and how their weighted taps are counted into a few responses a source and ear.

    An image's gains per band are its *shape* (how its walls absorb each band) times a number (its distance,
    its walls' overall absorption). The responses are made as ``components`` responses a source and ear,
    each heard through its spectral weighting (a mix of the band weights), and every image counted into
    them as *entries*: an image's taps, weighted, in one response. Two plans, whichever counts less:

    * **Shared shapes.** Images whose shapes are one (in a room whose walls absorb alike, the images of
      one order) are counted into one response: one entry an image, one response per shape, the same
      weighting for every source. A room that absorbs alike at every frequency has one shape and needs no
      weighting at all.
    * **Band mixes.** Otherwise the gains of a source's images, a matrix ``(images, 7)``, are factored
      (singular value decomposition ``U·Σ·Vᵀ``): ``rank`` responses (the columns of ``U·Σ``), each heard
      through its mix ``Vᵀ`` of the band weights; an image is an entry of each.

    Shared shapes are taken when there are no more of them than the band mixes' rank: as many FFTs, and a
    third of the entries for three orders (each image in one response instead of in every one).

    Attributes:
        azimuth: ``(images,)`` room azimuths, all sources' images one after the other.
        elevation: ``(images,)`` elevations.
        images: ``(entries,)`` the image each entry counts.
        weights: ``(entries,)`` its weight in its response.
        components: Responses a source and ear.
        shapes: ``(sources or 1, components, bins)`` each response's spectral weighting (None: one response,
            unweighted).
        rows: ``(entries,)`` the response each entry is counted into (``component · sources + source``).
        index: ``(entries · ears · taps,)`` where each weighted tap goes in the responses
            ``(components, sources, ears, length)``.
    """

    azimuth: npt.NDArray[np.float64]
    elevation: npt.NDArray[np.float64]
    images: npt.NDArray[np.intp]
    weights: npt.NDArray[np.float64]
    components: int
    shapes: npt.NDArray[np.float64] | None
    rows: npt.NDArray[np.intp]
    index: npt.NDArray[np.intp]

    @classmethod
    def of(cls, sources: list[_SourceImages], length: int, taps: int,
           band_weights: npt.NDArray[np.float64]) -> _ImagePlan:
        """The plan of *sources*' images into rows of *length* samples, each image's response *taps* long."""
        count = len(sources)
        gains = np.concatenate([s.gains for s in sources]) if sources else np.zeros((0, band_weights.shape[0]))
        owner = np.repeat(np.arange(count), [len(s.starts) for s in sources]).astype(np.intp)
        shared = _shared_shapes(gains)
        mixes = _band_mixes(sources) if shared is not None and len(shared[2]) > 1 else None
        if shared is not None and (mixes is None or len(shared[2]) <= mixes[3].shape[1]):
            group, scale, shapes = shared
            order = np.argsort(group, kind="stable")           # response by response: the counting runs in order
            images, weights, component = order.astype(np.intp), scale[order], group[order]
            flat = len(shapes) == 1 and bool(np.all(shapes[0] == shapes[0, 0]))
            weighting = None if flat else (shapes @ band_weights)[np.newaxis]
            if flat:
                weights = weights * shapes[0, 0]
        else:
            images, weights, component, mix = mixes if mixes is not None else _band_mixes(sources)
            weighting = mix @ band_weights
        components = 1 if weighting is None else weighting.shape[1]
        starts = np.concatenate([s.starts for s in sources]) if sources else np.zeros(0, dtype=np.int64)
        # Tap t of entry j's ear e: at (row · 2 + e) · length + start + t.
        rows = component * count + owner[images]
        offset = (rows * 2 * length + starts[images])[:, np.newaxis, np.newaxis]
        index = offset + (np.arange(2) * length)[:, np.newaxis] + np.arange(taps)
        return cls(np.concatenate([s.azimuth for s in sources]) if sources else np.zeros(0),
                   np.concatenate([s.elevation for s in sources]) if sources else np.zeros(0),
                   images, weights, components, weighting, rows, index.ravel())


def _shared_shapes(gains: npt.NDArray[np.float64]) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.float64],
                                                             npt.NDArray[np.float64]] | None:
    """Each image's shape (an index), its scale and the shapes ``(shapes, bands)`` of *gains* ``(images, bands)``.

    None when there are more shapes than bands (the band mixes need fewer responses then). A silent image
    has scale 0 in the first shape.
    """
    peak = gains.max(axis=1, initial=0.0)
    heard = peak > 0.0
    normal = gains[heard] / peak[heard, np.newaxis]
    group = np.zeros(len(gains), dtype=np.intp)
    found = np.zeros(len(normal), dtype=np.intp)
    shapes: list[npt.NDArray[np.float64]] = []
    pending = np.arange(len(normal))
    while len(pending):
        if len(shapes) == gains.shape[1]:
            return None
        first = normal[pending[0]]
        same = np.max(np.abs(normal[pending] - first), axis=1) <= _SAME_SHAPE
        found[pending[same]] = len(shapes)
        shapes.append(first)
        pending = pending[~same]
    group[heard] = found
    return group, np.where(heard, peak, 0.0), np.array(shapes) if shapes else np.ones((1, gains.shape[1]))


def _band_mixes(sources: list[_SourceImages]) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.float64],
                                                       npt.NDArray[np.intp], npt.NDArray[np.float64]]:
    """Entries (image, weight, component) and each source's band mixes ``(sources, rank, bands)``, by SVD.

    The entries are in order of component, then image.
    """
    factors: list[tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]] = []
    bands = sources[0].gains.shape[1] if sources else 0
    for source in sources:
        if len(source.gains) == 0:
            factors.append((np.zeros((0, 1)), np.ones((1, bands))))
            continue
        u, sigma, vt = np.linalg.svd(source.gains, full_matrices=False)
        rank = max(1, int(np.sum(sigma > sigma[0] * 1e-12)))
        factors.append((u[:, :rank] * sigma[:rank], vt[:rank]))
    width = max((f[0].shape[1] for f in factors), default=1)
    sizes = [len(s.starts) for s in sources]
    images = sum(sizes)
    weights = np.zeros((width, images))
    mixes = np.zeros((len(sources), width, bands))
    for i, (at, (u, mix)) in enumerate(zip(np.cumsum([0, *sizes])[:-1], factors, strict=True)):
        weights[:u.shape[1], at:at + len(u)] = u.T
        mixes[i, :mix.shape[0]] = mix
    component = np.repeat(np.arange(width), images).astype(np.intp)
    image = np.tile(np.arange(images), width).astype(np.intp)
    return image, weights.ravel(), component, mixes
