"""Several sources in the room: a mixture over room azimuth that explains every glimpse, fed frame by frame.

Each unit (a frame in a band, :mod:`._glimpses`) is taken to come from one of
the sources or from a diffuse background (reverberation, noise), with the
posterior p_u(θ) its log-likelihood gives under a flat prior. Turned into the
room frame with the head's azimuth at its frame, it says where in the room its
source is. The sources are the weights π(θ) of a mixture over the 1° grid, plus
a uniform background of weight β::

    p(unit u) = Σ_θ π(θ) p_u(θ) + β / 360

found by expectation-maximisation over the units' weights w_u (Dempster, Laird
& Rubin 1977): each unit is shared among the directions by its responsibility
π(θ) p_u(θ) / p(u), and π and β become the shares of all units. Sources are
the peaks of π.

This is the seed's layer (B), audio-motor localisation: every frame counts
with the head's azimuth at its time, a still head as a turning one. A front/back
mirror image fits the frames of one head azimuth only; once the head has
turned, the true direction explains the units of every frame and takes their
weight, and the mirror image's fades (where adding log-likelihoods would only
work for one source, a mixture keeps several). With a still head nothing tells
a mirror image from its source but the templates' spectral detail, so
:meth:`RoomAzimuthFilter.sources` leaves out a weaker peak at the mirror image
of a stronger one.

The mixture's maximum-likelihood weights are spiky (the nonparametric MLE of a
mixing distribution is discrete: Lindsay, Ann. Statist. 11(1), 1983): evidence
spread over a region, such as a room's reflections heard from several head
azimuths, gathers into a spike as heavy as a quiet talker. Once the head has
turned, a peak counts only if it explains its units, which its neighbours and
the background would not (:meth:`RoomAzimuthFilter.gain`, decision 45).

Memory is bounded: the units of the last ``capacity`` frames are kept (their
room-frame posteriors, float32) and iterated over; older ones are folded into
fixed sums of their responsibilities at the time (stochastic EM, Cappé &
Moulines, JRSS B 71(3), 2009).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from ._errors import LocalisationError
from ._glimpses import Glimpses, tempered
from ._hrir_set import wrap_degrees
from ._likelihood import GRID_DEGREES

__all__ = ["SourceAzimuth", "RoomAzimuthFilter", "SourceCounting", "pick_sources", "mirror_image", "unit_posteriors",
           "TURNING_FRONT_BACK_WEIGHT"]

_GRID = len(GRID_DEGREES)
#: The share of the templates' front/back preference a filter keeps when the head is to turn (set on training
#: rooms and heads, ``examples/localisation_training.py``: the KEMAR and a spherical head, never the experiment's).
TURNING_FRONT_BACK_WEIGHT = 0.15


@dataclasses.dataclass(frozen=True)
class SourceAzimuth:
    """One source found.

    Attributes:
        azimuth: Degrees in [-180, 180), in the frame named where it is given (room or head).
        confidence: The share of its region's probability that lies within ±10° of it: its region is
            the azimuths nearer it than any other source found, and the background's share of them
            (about 0.5 for a front/back tie; low when reverberation or noise explain most there).
        weight: Its share of the mixture (the units it explains), summed over ±10°: the sources'
            weights and the background's make 1.
        power: The share of the glimpses' power it explains (the loudest source has the most).
    """

    azimuth: float
    confidence: float
    weight: float
    power: float = 0.0


@dataclasses.dataclass(frozen=True)
class SourceCounting:
    """How many sources to report when the number is not given, and how far apart.

    Attributes:
        min_weight: The least mixture weight of a peak (within ±``peak_width``) that counts as a source.
        peak_width: Degrees either side of a peak whose weight ranks it.
        most: The most sources reported.
        separation: Degrees between two sources at least.
        mirror_ratio: A peak at the front/back mirror image of a stronger source (seen from a head that
            did not turn) is left out unless its weight is at least this share of the stronger one's.
        min_evidence: The least share of what was heard (the units' weights, noise included) that rose
            above the learnt noise for anything to be detected: below it, counting finds no source, and
            sources asked for have their confidences scaled by the share over this (noise alone heard).
        min_gain: The least log-likelihood gain of a peak that counts as a source once the head has
            turned, nats per unit of its weight: how much likelier the units heard are with it than with
            the rest of the mixture alone (:meth:`RoomAzimuthFilter.gain`). A talker's units point at it
            and nowhere else (a gain of 0.2 to 1.5); a spike the mixture made of evidence spread over a
            region, such as a room's reflections heard from several head azimuths, explains them hardly
            better than its neighbours and the background do (under 0.1).
    """

    min_weight: float = 0.05
    peak_width: float = 2.0
    most: int = 6
    separation: float = 10.0
    mirror_ratio: float = 0.5
    min_evidence: float = 0.05
    min_gain: float = 0.15


def mirror_image(azimuth: npt.ArrayLike, head: float) -> npt.NDArray[np.float64]:
    """The front/back mirror image of room *azimuth* (degrees) across the interaural axis of a head at *head*."""
    return np.asarray(wrap_degrees(2.0 * head + 180.0 - np.asarray(azimuth, dtype=np.float64)))


def _window_mass(values: npt.NDArray[np.float64], centre: float, width: float = 10.0) -> float:
    return float(values[np.abs(wrap_degrees(GRID_DEGREES - centre)) <= width].sum())


def pick_sources(weights: npt.NDArray[np.float64], count: int | None, counting: SourceCounting = SourceCounting(),
                 still_head: float | None = None, power: npt.NDArray[np.float64] | None = None,
                 background: float = 0.0, evidence: float = 1.0,
                 gain: Callable[[int], float] | None = None) -> list[SourceAzimuth]:
    """The sources among the peaks of a distribution over the 1° grid, strongest first.

    Args:
        weights: ``(360,)`` mixture weights (or any non-negative distribution) in one frame.
        count: How many to report (fewer only when the distribution has fewer peaks), or None:
            as many peaks as weigh at least ``counting.min_weight``.
        counting: The rules of the count.
        still_head: The azimuth of a head that did not turn (in the same frame), whose front/back
            mirror images are suspect; None when it turned.
        power: ``(360,)`` the glimpses' power each direction explains (for :attr:`SourceAzimuth.power`).
        background: The background's weight (spread evenly round the circle, it lowers the confidences).
        evidence: The share of what was heard that rose above the noise (1: all, or no noise learnt):
            below ``counting.min_evidence``, nothing is counted and the confidences are scaled down.
        gain: The log-likelihood gain of the peak at a grid index (:meth:`RoomAzimuthFilter.gain`):
            when counting, a peak below ``counting.min_gain`` is no source. None: not judged.
    """
    values = np.asarray(weights, dtype=np.float64)
    local = np.flatnonzero((values >= np.roll(values, 1)) & (values > np.roll(values, -1)))
    # Peaks are ranked by the weight at them (±2°): a source's share gathers into a few degrees, while
    # the spread of reverberation is low and wide.
    masses = {int(i): _window_mass(values, float(i), counting.peak_width) for i in local}
    order = sorted(masses, key=lambda i: -masses[i])
    most = counting.most if count is None else count
    if count is None and evidence < counting.min_evidence:
        return []                        # noise alone: nothing detected
    chosen: list[int] = []
    deferred: list[int] = []
    for index in order:
        if len(chosen) >= most or (count is None and masses[index] < counting.min_weight):
            break
        if any(abs(float(wrap_degrees(index - c))) < counting.separation for c in chosen):
            continue
        if still_head is not None and any(
                abs(float(wrap_degrees(mirror_image(c, still_head) - index))) <= counting.separation
                and masses[index] < counting.mirror_ratio * masses[c] for c in chosen):
            deferred.append(index)       # probably the mirror image of a source already found
            continue
        if count is None and gain is not None and gain(index) < counting.min_gain:
            continue                     # spread evidence the mixture gathered into a spike
        chosen.append(index)
    if count is not None:
        # Asked for more than the clear peaks: the suspected mirror images come last.
        for index in deferred:
            if len(chosen) >= count:
                break
            if all(abs(float(wrap_degrees(index - c))) >= counting.separation for c in chosen):
                chosen.append(index)
    detected = min(1.0, evidence / counting.min_evidence) if counting.min_evidence > 0 else 1.0
    return _described(values, chosen, power, background, detected)


def _described(values: npt.NDArray[np.float64], chosen: list[int], power: npt.NDArray[np.float64] | None,
               background: float, detected: float = 1.0) -> list[SourceAzimuth]:
    if not chosen:
        return []
    peaks = np.array([float(GRID_DEGREES[c]) for c in chosen])
    nearest = np.argmin(np.abs(wrap_degrees(GRID_DEGREES[:, np.newaxis] - peaks[np.newaxis, :])), axis=1)
    total_power = float(power.sum()) if power is not None else 0.0
    sources = []
    for k, index in enumerate(chosen):
        inside = nearest == k
        region = float(values[inside].sum()) + background * float(inside.sum()) / _GRID
        # Its ±10° that are its own (another source may be nearer than 20°).
        near = float(values[inside & (np.abs(wrap_degrees(GRID_DEGREES - index)) <= 10.0)].sum())
        share = _window_mass(power, float(index)) / total_power if power is not None and total_power > 0 else 0.0
        confidence = detected * near / region if region > 0 else 0.0
        sources.append(SourceAzimuth(_refined(values, index), confidence, near, share))
    return sources


def _refined(values: npt.NDArray[np.float64], index: int) -> float:
    """The peak at grid *index* refined by a parabola through its neighbours, degrees in [-180, 180)."""
    below, at, above = values[index - 1], values[index], values[(index + 1) % _GRID]
    curvature = below - 2.0 * at + above
    offset = 0.5 * (below - above) / curvature if curvature < 0 else 0.0
    return float(wrap_degrees(GRID_DEGREES[index] + offset))


class RoomAzimuthFilter:
    """The mixture of sources over room azimuth, fed with glimpses and the head's azimuth at each frame.

    Args:
        capacity: Frames whose units are kept and iterated over; older ones are folded into fixed sums.
        iterations: EM iterations per :meth:`fit`.
        counting: How sources are counted and told apart (:meth:`sources`).
        sparsity: Weight each degree loses to the background at each iteration (a sparse prior, MAP-EM):
            the scattered units of reverberation go to the background instead of making peaks of their own.
        front_back_weight: How much of the templates' front/back preference each unit keeps
            (:func:`~._glimpses.tempered`): 1 for a head that stays still (it is all there is to tell
            front from back), less for one that turns (:data:`TURNING_FRONT_BACK_WEIGHT`), which tells
            them apart on any head, whatever its pinnae.
    """

    def __init__(self, capacity: int = 256, iterations: int = 40,
                 counting: SourceCounting = SourceCounting(), sparsity: float = 0.0,
                 front_back_weight: float = 1.0) -> None:
        if capacity < 1 or iterations < 1 or not 0.0 <= sparsity < 1.0 / _GRID \
                or not 0.0 <= front_back_weight <= 1.0:
            raise LocalisationError("a filter keeps at least one frame, iterates at least once, its sparsity "
                                    f"is in [0, 1/{_GRID}) and its front/back weight in [0, 1]")
        self.capacity, self.iterations, self.counting, self.sparsity = capacity, iterations, counting, sparsity
        self.front_back_weight = front_back_weight
        self.clear()

    def clear(self) -> None:
        """Forget everything fed."""
        self._posteriors: list[npt.NDArray[np.float32]] = []      # per batch: (units, 360), room frame
        self._weights: list[npt.NDArray[np.float64]] = []         # per batch: (units,)
        self._powers: list[npt.NDArray[np.float64]] = []          # per batch: (units,)
        self._frames: list[int] = []                              # per batch
        self._folded = np.zeros(_GRID)                            # responsibilities of folded units
        self._folded_background = 0.0
        self._folded_power = np.zeros(_GRID)
        self._folded_weight = 0.0
        self._pi = np.full(_GRID, 0.8 / _GRID)
        self._background = 0.2
        self._heads: list[float] = []
        self._heard = 0.0                                         # the units' weights, noise included
        self._above_noise = 0.0                                   # their weights above the noise
        self._fitted = True
        #: Frames fed since the last :meth:`clear`.
        self.frames = 0

    def add(self, glimpses: Glimpses, heads: npt.ArrayLike) -> None:
        """Feed the glimpses of consecutive frames and the head's room azimuth at each frame (degrees)."""
        head = np.broadcast_to(np.asarray(heads, dtype=np.float64), (glimpses.frames,))
        if glimpses.frames == 0:
            return
        posterior = unit_posteriors(glimpses, self.front_back_weight)
        room = _to_room(posterior, head).reshape(-1, _GRID)
        weight = glimpses.weight.reshape(-1)
        noise = 0.0 if glimpses.noise_weight is None else float(glimpses.noise_weight.sum())
        self._above_noise += float(weight.sum())
        self._heard += float(weight.sum()) + noise
        keep = weight > 0
        self._posteriors.append(room[keep].astype(np.float32))
        self._weights.append(weight[keep])
        self._powers.append(glimpses.power.reshape(-1)[keep])
        self._frames.append(glimpses.frames)
        self._heads.extend(float(h) for h in head[[0, -1]])
        self.frames += glimpses.frames
        self._fitted = False
        while sum(self._frames) > self.capacity and len(self._frames) > 1:
            self._fold_oldest()

    def _fold_oldest(self) -> None:
        """Fix the oldest batch's responsibilities under the mixture now, and let its units go."""
        self.fit()
        posterior, weight, power = self._posteriors.pop(0), self._weights.pop(0), self._powers.pop(0)
        self._frames.pop(0)
        mixture = posterior @ self._pi + self._background / _GRID
        share = weight / np.maximum(mixture, 1e-300)
        self._folded += self._pi * (share @ posterior)
        self._folded_background += self._background / _GRID * float(share.sum())
        self._folded_power += self._pi * ((power / np.maximum(mixture, 1e-300)) @ posterior)
        self._folded_weight += float(weight.sum())

    def fit(self) -> None:
        """Run the EM iterations over the units kept (done by :meth:`distribution` and :meth:`sources` as needed)."""
        if self._fitted:
            return
        self._fitted = True
        if not self._posteriors:
            return
        posterior = np.concatenate(self._posteriors)
        weight = np.concatenate(self._weights)
        total = weight.sum() + self._folded_weight
        if total <= 0:
            return
        pi, background = self._pi, self._background
        if pi.sum() <= 0:
            pi = np.full(_GRID, 0.8 / _GRID)
        for _ in range(self.iterations):
            # float32 products (the posteriors are kept so): half the memory traffic of float64.
            mixture = posterior @ pi.astype(np.float32) + np.float32(background / _GRID)
            share = (weight / np.maximum(mixture, 1e-30)).astype(np.float32)
            pi = (self._folded + pi * (share @ posterior)) / total
            background = (self._folded_background + background / _GRID * float(share.sum())) / total
            if self.sparsity:
                # A sparse prior on the directions (MAP-EM): what each degree holds below the sparsity goes to
                # the background, which then takes the scattered units of reverberation.
                kept = np.maximum(pi - self.sparsity, 0.0)
                background += float(pi.sum() - kept.sum())
                pi = kept
        self._pi, self._background = pi, background

    def distribution(self) -> tuple[npt.NDArray[np.float64], float]:
        """The mixture's weight of each room azimuth on the 1° grid, and the background's (they sum to 1)."""
        self.fit()
        return self._pi.copy(), self._background

    def explained_power(self) -> npt.NDArray[np.float64]:
        """``(360,)`` the glimpses' power each room azimuth explains (responsibilities times power)."""
        self.fit()
        power = self._folded_power.copy()
        for posterior, powers in zip(self._posteriors, self._powers, strict=True):
            mixture = posterior @ self._pi + self._background / _GRID
            power += self._pi * ((powers / np.maximum(mixture, 1e-300)) @ posterior)
        return power

    @property
    def evidence(self) -> float:
        """The share of the units' weight heard (noise included) that rose above the learnt noise.

        1 when no noise was learnt (nothing then tells a source from the noise), 0 before anything was heard.
        """
        return self._above_noise / self._heard if self._heard > 0 else 0.0

    @property
    def still_head(self) -> float | None:
        """The head's azimuth when it stayed within a few degrees through every frame fed, else None."""
        if not self._heads:
            return None
        heads = np.asarray(self._heads)
        spread = np.abs(wrap_degrees(heads - heads[0]))
        return float(heads[0] + wrap_degrees(heads - heads[0]).mean()) if spread.max() <= 5.0 else None

    def sources(self, count: int | None = None) -> list[SourceAzimuth]:
        """The sources found, strongest first, room azimuths (see :func:`pick_sources`).

        Args:
            count: How many (None: as many as the counting rules find).
        """
        if self.frames == 0:
            return []
        weights, background = self.distribution()
        # A still head's peak and its mirror image explain the same units (only the templates' spectral detail
        # tells them apart): the gain judges the peaks of a head that turned, the mirror rule a still head's.
        still = self.still_head
        return pick_sources(weights, count, self.counting, still, self.explained_power(), background,
                            self.evidence, self.gain if count is None and still is None else None)

    def gain(self, index: int) -> float:
        """How much the peak at grid *index* (its ±10°) explains: nats per unit of its weight.

        The units kept (the last ``capacity`` frames') are weighed by their likelihood under the
        mixture and under the rest of it alone (the peak's weight shared among the other directions
        in proportion, no refit: an upper bound of what losing it costs), and the weighted mean of the
        log of the ratio is divided by the peak's weight. A source whose units point at it alone gains
        the log of how much surer they are of it than of anything else; a spike made of evidence
        spread over a region gains little, its neighbours and the background explaining the same units.

        Returns:
            The gain; 0 for a peak that holds no weight, infinity when nothing could replace it (no other
            direction holds any weight, or every unit has been folded): such a peak is not judged.
        """
        self.fit()
        pi, background = self._pi, self._background
        window = np.abs(wrap_degrees(GRID_DEGREES - GRID_DEGREES[index % _GRID])) <= 10.0
        held, total = float(pi[window].sum()), float(pi.sum())
        if held <= 0.0 or held >= total or not self._posteriors:
            return math.inf if held > 0.0 else 0.0
        rest = (np.where(window, 0.0, pi) * (total / (total - held))).astype(np.float32)
        mixture, floor = pi.astype(np.float32), np.float32(background / _GRID)
        gained = weighed = 0.0
        for posterior, weight in zip(self._posteriors, self._weights, strict=True):   # batch by batch: no copy
            with_it = np.log(np.maximum(posterior @ mixture + floor, 1e-30))
            without = np.log(np.maximum(posterior @ rest + floor, 1e-30))
            gained += float(weight @ (with_it - without).astype(np.float64))
            weighed += float(weight.sum())
        return gained / (weighed * held) if weighed > 0 else 0.0


def unit_posteriors(glimpses: Glimpses, front_back_weight: float = 1.0) -> npt.NDArray[np.float64]:
    """``(frames, bands, 360)`` each unit's head-frame posterior, its unreliable share spread evenly.

    Args:
        glimpses: The units.
        front_back_weight: How much of the templates' front/back preference counts (:func:`~._glimpses.tempered`).
    """
    log_likelihood = tempered(glimpses.log_likelihood, front_back_weight)
    posterior = np.exp(log_likelihood - log_likelihood.max(axis=-1, keepdims=True))
    posterior /= posterior.sum(axis=-1, keepdims=True)
    if glimpses.reliability is not None:
        reliability = glimpses.reliability[..., np.newaxis]
        posterior = reliability * posterior + (1.0 - reliability) / _GRID
    return np.asarray(posterior)


def _to_room(posterior: npt.NDArray[np.float64], heads: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """``(frames, bands, 360)`` head-frame values read in the room frame, frame by frame (linear interpolation)."""
    position = np.mod(GRID_DEGREES[np.newaxis, :] - heads[:, np.newaxis], 360.0)              # (frames, 360)
    lower = np.floor(position).astype(np.intp)
    fraction = (position - lower)[:, np.newaxis, :]
    lower %= _GRID
    upper = (lower + 1) % _GRID
    below = np.take_along_axis(posterior, np.broadcast_to(lower[:, np.newaxis, :], posterior.shape), axis=-1)
    above = np.take_along_axis(posterior, np.broadcast_to(upper[:, np.newaxis, :], posterior.shape), axis=-1)
    return np.asarray(below * (1.0 - fraction) + above * fraction)
