"""Likelihoods over azimuth: peaks, confidence, and estimates from several head azimuths combined in the room.

A likelihood is kept as its logarithm on a 1° grid round the circle. One
estimated with the head at azimuth ψ is in the head frame; the same direction
in the room is at θ_room = θ_head + ψ. Estimates taken at different head
azimuths of a source that does not move are independent observations of one
room azimuth, so their log-likelihoods, turned into the room frame, add
(Ma, May & Brown, IEEE/ACM TASLP 25(12), 2017, combine the posteriors of
frames taken during a head turn in the same way). A front/back mirror image
that fits one head azimuth fits no other, so it loses.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable

import numpy as np
import numpy.typing as npt

from ._errors import LocalisationError
from ._hrir_set import wrap_degrees

__all__ = ["AzimuthLikelihood", "combine_in_room", "GRID_DEGREES"]

#: The azimuths of every likelihood: 0°, 1°, …, 359°.
GRID_DEGREES = np.arange(360, dtype=np.float64)
GRID_DEGREES.setflags(write=False)


@dataclasses.dataclass(frozen=True, eq=False)
class AzimuthLikelihood:
    """The log-likelihood of each azimuth on :data:`GRID_DEGREES`.

    Attributes:
        log_likelihood: ``(360,)`` natural-log likelihoods (any offset).
        frame: ``"head"`` (azimuths relative to the nose) or ``"room"``.
    """

    log_likelihood: npt.NDArray[np.float64]
    frame: str = "head"

    def posterior(self) -> npt.NDArray[np.float64]:
        """The likelihoods normalised to sum to 1 (a flat prior)."""
        shifted = np.exp(self.log_likelihood - self.log_likelihood.max())
        return np.asarray(shifted / shifted.sum())

    def peak(self) -> float:
        """The most likely azimuth in degrees, [-180, 180), refined between grid points by a parabola."""
        values = self.log_likelihood
        best = int(np.argmax(values))
        below, at, above = values[best - 1], values[best], values[(best + 1) % len(values)]
        curvature = below - 2.0 * at + above
        offset = 0.5 * (below - above) / curvature if curvature < 0 else 0.0
        return float(wrap_degrees(GRID_DEGREES[best] + offset))

    def peaks(self, count: int = 2, separation: float = 20.0) -> list[tuple[float, float]]:
        """The *count* largest local maxima at least *separation* degrees apart: ``(azimuth°, posterior mass)``.

        The mass is the posterior within ±10° of the peak.
        """
        values = self.log_likelihood
        local = np.flatnonzero((values >= np.roll(values, 1)) & (values > np.roll(values, -1)))
        order = local[np.argsort(values[local])[::-1]]
        chosen: list[int] = []
        for index in order:
            if all(abs(float(wrap_degrees(GRID_DEGREES[index] - GRID_DEGREES[c]))) >= separation for c in chosen):
                chosen.append(int(index))
            if len(chosen) == count:
                break
        return [(float(wrap_degrees(GRID_DEGREES[c])), self.mass_near(float(GRID_DEGREES[c]))) for c in chosen]

    def mass_near(self, azimuth: float, width: float = 10.0) -> float:
        """The posterior probability that the azimuth is within ±*width* degrees of *azimuth*."""
        near = np.abs(wrap_degrees(GRID_DEGREES - azimuth)) <= width
        return float(self.posterior()[near].sum())

    def confidence(self, width: float = 10.0) -> float:
        """The posterior probability within ±*width* degrees of :meth:`peak` (about 0.5 for a front/back tie)."""
        return self.mass_near(self.peak(), width)

    def in_room(self, head_azimuth: float) -> AzimuthLikelihood:
        """This head-frame likelihood in the room frame, for a head at *head_azimuth* degrees."""
        if self.frame != "head":
            raise LocalisationError("only a head-frame likelihood can be turned into the room frame")
        return AzimuthLikelihood(_periodic_at(self.log_likelihood, GRID_DEGREES - head_azimuth), "room")

    def relative_to(self, head_azimuth: float) -> AzimuthLikelihood:
        """This room-frame likelihood seen from a head at *head_azimuth* degrees."""
        if self.frame != "room":
            raise LocalisationError("only a room-frame likelihood can be seen from a head")
        return AzimuthLikelihood(_periodic_at(self.log_likelihood, GRID_DEGREES + head_azimuth), "head")


def _periodic_at(values: npt.NDArray[np.float64], azimuths: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """*values* on the 1° grid read at *azimuths* (degrees), with linear interpolation round the circle."""
    position = np.mod(azimuths, 360.0)
    lower = np.floor(position).astype(np.intp) % 360
    weight = position - np.floor(position)
    return np.asarray(values[lower] * (1.0 - weight) + values[(lower + 1) % 360] * weight)


def combine_in_room(observations: Iterable[tuple[AzimuthLikelihood, float]]) -> AzimuthLikelihood:
    """Combine head-frame likelihoods taken at several head azimuths into one in the room frame.

    Args:
        observations: ``(likelihood, head_azimuth)`` pairs: a head-frame likelihood and the
            head's room azimuth (degrees, positive to the left) while its audio was taken.

    Returns:
        The room-frame likelihood of a source that stayed put.
    """
    total = np.zeros(len(GRID_DEGREES))
    seen = False
    for likelihood, head in observations:
        total += likelihood.in_room(head).log_likelihood
        seen = True
    if not seen:
        raise LocalisationError("no observation to combine")
    return AzimuthLikelihood(total, "room")


def radians(degrees: float) -> float:
    """Degrees to radians in (-π, π] (how the Two!Ears code reads azimuths)."""
    value = math.radians(float(wrap_degrees(degrees)))
    return math.pi if value == -math.pi else value
