"""Head movements that tell sources from their mirror images: Ma, May & Brown's turn, and turns chosen by information.

Two strategies, compared in the experiment (``docs/localisation.md``):

* **Ma, May & Brown** (IEEE/ACM TASLP 25(12), 2017; the Two!Ears ``HeadRotationKS`` and
  ``ConfusionSolvingKS``): listen, turn the head 20° towards the most likely source
  (left when it is on the left), listen again, add the two looks' posteriors in the room
  frame, and drop every peak that one look shows and the other does not (a front/back
  mirror image moves in the room when the head turns; a source does not).
  :func:`ma_turn` and :func:`ma_combine`; the posteriors are the glimpses' (summed,
  weighted) where theirs came from a DNN per frame.
* **The seed's layers (B) + (C)**: a :class:`~._mixture.RoomAzimuthFilter` fed by every
  frame with the head's azimuth at its time (frames heard while the head turns included),
  and turns chosen by :class:`TurnPlanner` to tell apart most of what is still confused.

:class:`TurnPlanner` scores a look from head azimuth ψ by the expected discrimination it
adds: for each pair of room azimuths (i, j) weighted by the mixture, p_i p_j, times how
confusable they still are after the looks made so far, Π_looks S(i − ψ_l, j − ψ_l), times how
different they would sound from ψ, 1 − S(i − ψ, j − ψ), where S is the similarity of the
templates' steering vectors (1: the same ears' cues). Pairs of a source and its mirror
image are confusable from a still head and tell apart once it turned; pairs already told
apart, or that no turn tells apart, add nothing. This is a pairwise (Bhattacharyya-like)
stand-in for the expected information gain of active hypothesis testing.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ._errors import LocalisationError
from ._glimpses import GlimpseAnalyser, Glimpses
from ._hrir_set import wrap_degrees
from ._likelihood import GRID_DEGREES
from ._mixture import SourceAzimuth, SourceCounting, mirror_image, pick_sources

__all__ = ["TurnPlanner", "ma_turn", "ma_combine", "posterior_sum", "MA_TURN"]

#: Ma, May & Brown's head turn, degrees.
MA_TURN = 20.0
#: Posterior a peak must keep in the other look not to be taken for a mirror image (Two!Ears' 0.02, relative).
_CONFIRMED = 0.02


def posterior_sum(glimpses: Glimpses, heads: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """The glimpses' posteriors, weighted and summed in the room frame: ``(360,)``, summing to 1.

    Args:
        glimpses: The evidence of consecutive frames.
        heads: The head's room azimuth at each frame (or one for all), degrees.
    """
    from ._mixture import _to_room, unit_posteriors

    head = np.broadcast_to(np.asarray(heads, dtype=np.float64), (glimpses.frames,))
    room = _to_room(unit_posteriors(glimpses), head)
    total = np.einsum("fb,fbg->g", glimpses.weight, room)
    return np.asarray(total / max(float(total.sum()), 1e-300))


def ma_turn(sources: list[SourceAzimuth], head: float) -> float:
    """The head azimuth of Ma et al.'s turn: 20° towards the most likely source (room azimuths, degrees)."""
    if not sources:
        raise LocalisationError("no source to turn towards")
    relative = float(wrap_degrees(sources[0].azimuth - head))
    return head + (MA_TURN if relative >= 0.0 else -MA_TURN)


def ma_combine(first: npt.NDArray[np.float64], first_head: float, second: npt.NDArray[np.float64],
               second_head: float, count: int | None,
               counting: SourceCounting = SourceCounting()) -> list[SourceAzimuth]:
    """Two looks' room-frame posteriors added, the mirror images one of them shows dropped; the sources found.

    Args:
        first: ``(360,)`` the first look's posterior sum (:func:`posterior_sum`), room frame.
        first_head: Its head azimuth, degrees.
        second: The second look's, after the turn.
        second_head: Its head azimuth.
        count: How many sources (None: counted).
        counting: The rules of the count.
    """
    combined = first + second
    dropped = np.zeros(len(GRID_DEGREES), dtype=bool)
    for look, other, head in ((first, second, first_head), (second, first, second_head)):
        peaks = [s.azimuth for s in pick_sources(look, None, SourceCounting(min_weight=_CONFIRMED * 5, most=12,
                                                                             separation=counting.separation))]
        for peak in peaks:
            ghost = float(mirror_image(peak, head))
            # A front/back pair in this look: the member the other look does not confirm is a mirror image.
            if not any(abs(float(wrap_degrees(ghost - p))) <= 10.0 for p in peaks):
                continue
            for member in (peak, ghost):
                near = np.abs(wrap_degrees(GRID_DEGREES - member)) <= 5.0
                if other[near].max() < _CONFIRMED * other.max():
                    dropped |= near
    return pick_sources(np.where(dropped, 0.0, combined) / 2.0, count, counting)


class TurnPlanner:
    """Chooses where the head looks from next: the turn expected to tell apart most of what is still confused.

    Args:
        analyser: The glimpses' analyser, whose templates give the similarity of directions.
        turns: The turns considered, degrees either way from where the head is.
    """

    def __init__(self, analyser: GlimpseAnalyser, turns: tuple[float, ...] = (10.0, 20.0, 30.0, 45.0, 60.0, 90.0)):
        self.turns = turns
        self.azimuths = analyser.template_azimuths                       # the templates, every 5°
        steering = np.conj(analyser._steering_conj)                     # (bins, 2, T)
        # Per band, the mean similarity |h_aᴴ h_b|² of its bins; then the mean over bands (each band one say).
        overlap = np.abs(np.einsum("ket,kes->kts", np.conj(steering), steering)) ** 2   # (bins, T, T)
        per_band = np.einsum("kts,kb->bts", overlap, analyser.membership) / analyser.membership.sum(0)[:, None, None]
        #: ``(T, T)`` similarity of template directions (1 on the diagonal).
        self.similarity = per_band.mean(axis=0)
        self._step = 360.0 / len(self.azimuths)

    def _cells(self, head: float) -> npt.NDArray[np.intp]:
        """For each room cell (every template spacing from 0°), the template cell it is heard at from *head*."""
        room = np.arange(len(self.azimuths)) * self._step
        return np.asarray(np.round(np.mod(room - head, 360.0) / self._step).astype(np.intp) % len(self.azimuths))

    def _masses(self, weights: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """The mixture's weights summed into the template cells of the room (normalised)."""
        cells = np.round(GRID_DEGREES / self._step).astype(np.intp) % len(self.azimuths)
        masses = np.bincount(cells, weights=weights, minlength=len(self.azimuths))
        return np.asarray(masses / max(float(masses.sum()), 1e-300))

    def gain(self, weights: npt.NDArray[np.float64], looks: list[float], head: float) -> float:
        """The expected discrimination a look from *head* adds, after *looks* (head azimuths, degrees)."""
        p = self._masses(weights)
        confused = np.ones_like(self.similarity)
        for look in looks:
            cells = self._cells(look)
            confused *= self.similarity[np.ix_(cells, cells)]
        cells = self._cells(head)
        different = 1.0 - self.similarity[np.ix_(cells, cells)]
        return float(p @ (confused * different) @ p)

    def next_head(self, weights: npt.NDArray[np.float64], looks: list[float], head: float,
                  limits: tuple[float, float] = (-180.0, 180.0)) -> float:
        """The head azimuth to look from next (degrees): the most informative turn within *limits*.

        Args:
            weights: ``(360,)`` the room filter's mixture weights.
            looks: The head azimuths looked from so far.
            head: Where the head is now.
            limits: The lowest and highest head azimuths allowed.
        """
        low, high = limits
        candidates = [head + sign * turn for turn in self.turns for sign in (1.0, -1.0)
                      if low <= head + sign * turn <= high]
        if not candidates:
            return min(high, max(low, head))
        gains = [self.gain(weights, looks, target) for target in candidates]
        # Of the turns within 10% of the most informative, one towards the strongest direction (which brings
        # the sources nearer the nose, where the lateral angle is heard most finely, as Ma et al. turned),
        # then the smallest.
        strongest = float(wrap_degrees(GRID_DEGREES[int(np.argmax(weights))] - head))
        side = 1.0 if strongest >= 0.0 else -1.0
        best = max(gains)
        near_best = [c for c, g in zip(candidates, gains, strict=True) if g >= 0.9 * best]
        return min(near_best, key=lambda c: ((c - head) * side < 0, abs(c - head)))
