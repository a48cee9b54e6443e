"""Active listening: a head that can be turned, and the policy that turns it to tell front from back.

A still head hears a source at θ and its mirror image 180° − θ across the interaural axis
with nearly the same cues: only the pinnae's and torso's spectral detail tells them apart,
the first detail lost on a real head or in a reverberant room. Turning the head changes the
lateral angle of the two hypotheses in opposite ways: a source on the left in front moves
towards the nose when the head turns left, its mirror image behind moves away from it. So
estimates taken at several head azimuths, combined in the room frame
(as :func:`~._likelihood.combine_in_room` does), keep the true direction and drop the mirror image
(Ma, May & Brown, IEEE/ACM TASLP 25(12), 2017, combine frames taken during head turns).

:class:`FrontBackPolicy` is the decision, pure: it takes the estimates as they come and says
where to look from next, and when the source is found; :class:`TurnableHead` is what it needs
from a robot, offered by the components that turn a head (``kemar``, ``kemarcapture``,
``morse_kemar``) and found by type on their host.
"""

from __future__ import annotations

import asyncio
import dataclasses
import math
from collections.abc import Awaitable, Callable
from typing import Any, Protocol

from ._errors import LocalisationError
from ._hrir_set import wrap_degrees
from ._likelihood import AzimuthLikelihood
from ._localiser import AzimuthEstimate

__all__ = ["TurnableHead", "HeadTurnFailed", "FrontBackPolicy"]


class HeadTurnFailed(LocalisationError):
    """The head was asked to turn and did not get there (not homed, a drive fault, interrupted)."""


class _Requested(Protocol):
    """What a turn needs of a request: its end, how it ended."""

    id: str
    status: str
    exception: Any
    output: Any
    ended: asyncio.Event


class _Serving(Protocol):
    """What a turn needs of the component that turns the head: its requests."""

    async def send(self, name: str, raw_input: Any = None) -> Any: ...
    async def abort(self, request_id: str) -> Any: ...
    async def clean(self, request_id: str) -> None: ...


@dataclasses.dataclass(frozen=True)
class TurnableHead:
    """A head that active listening may turn (a capability its component provides by type).

    Attributes:
        turn_to: ``await turn_to(azimuth, speed)`` turns the head to *azimuth* (degrees in the room,
            positive to the left) at up to *speed* deg/s and returns the azimuth reached once it is
            there; raises :class:`HeadTurnFailed` when it cannot.
        position: ``await position()`` is the head's azimuth now, degrees (NaN when the head does not
            answer: the audio of that moment goes without a head azimuth).
        limits: The lowest and highest azimuths a turn may ask for, degrees.
    """

    turn_to: Callable[[float, float], Awaitable[float]]
    position: Callable[[], Awaitable[float]]
    limits: tuple[float, float] = (-89.5, 89.5)

    @classmethod
    def by_service(cls, component: _Serving, position: Callable[[], Awaitable[float]],
                   limits: tuple[float, float], service: str = "MoveAbsolutePosition") -> TurnableHead:
        """A head turned by a service of its own component (``target`` in degrees, ``velocity`` in deg/s).

        Each turn is a request of that service, so it interrupts and is interrupted by the
        component's other motions, shows in its state and events, and is cleaned once ended;
        a turn cancelled (its caller interrupted) aborts the request, which stops the head.

        Args:
            component: The component that turns the head (``kemar``, ``morse_kemar``...).
            position: Reads the head's azimuth now (degrees; NaN when the head does not answer).
            limits: The lowest and highest azimuths a turn may ask for, degrees.
            service: The service that turns the head to an azimuth and ends once it is there.
        """

        async def turn_to(azimuth: float, speed: float) -> float:
            request: _Requested = await component.send(service, {"target": float(azimuth), "velocity": float(speed)})
            try:
                await request.ended.wait()
            except asyncio.CancelledError:
                await asyncio.shield(component.abort(request.id))
                raise
            finally:
                if request.ended.is_set():
                    await component.clean(request.id)
            if request.status != "done":
                raise HeadTurnFailed(f"{service} to {azimuth:.1f} deg ended in {request.exception}")
            output = request.output or {}
            reached = output.get("position") if isinstance(output, dict) else None
            return float(reached) if isinstance(reached, int | float) else await position()

        return cls(turn_to, position, limits)

    def clip(self, azimuth: float) -> float:
        """*azimuth* (degrees) brought within the head's limits."""
        low, high = self.limits
        return min(high, max(low, float(wrap_degrees(azimuth))))


@dataclasses.dataclass
class FrontBackPolicy:
    """Where to turn the head next to tell front from back, and when the source is found.

    Feed it every estimate (with its head azimuth) as it comes: still or turning, they add in
    the room frame. It asks for at least ``min_turns`` looks from another head azimuth, since a
    still head's front/back decision rests on spectral detail that the templates may share with
    no real head; it stops once the posterior within ±10° of the room peak reaches ``confidence``
    (or after ``max_turns``).

    Args:
        turn: Degrees each look turns the head from where it started, towards the source's side first.
        limits: The head's limits, degrees.
        confidence: The posterior mass within ±10° of the peak that settles it.
        min_turns: Looks from another azimuth before it may settle.
        max_turns: Looks after which it settles whatever the confidence.
    """

    turn: float = 30.0
    limits: tuple[float, float] = (-89.5, 89.5)
    confidence: float = 0.9
    min_turns: int = 1
    max_turns: int = 4
    #: Head azimuths looked from so far (the start first), degrees.
    looks: list[float] = dataclasses.field(default_factory=list, init=False)
    #: Estimates combined so far.
    estimates: int = dataclasses.field(default=0, init=False)
    _room: AzimuthLikelihood | None = dataclasses.field(default=None, init=False, repr=False)
    _start: float | None = dataclasses.field(default=None, init=False, repr=False)
    _side: float = dataclasses.field(default=1.0, init=False, repr=False)

    def __post_init__(self) -> None:
        if not self.turn > 0 or not 0 < self.confidence < 1 or self.min_turns > self.max_turns:
            raise LocalisationError("a policy needs a positive turn, a confidence in (0, 1) and "
                                    "min_turns <= max_turns")

    def add(self, estimate: AzimuthEstimate) -> None:
        """Combine an estimate taken at its head azimuth.

        Raises:
            LocalisationError: for an estimate without a head azimuth (audio that carried none).
        """
        room = estimate.room
        if room is None:
            raise LocalisationError("an estimate without the head's azimuth cannot be turned into the room")
        # Independent observations of one room azimuth: their log-likelihoods add.
        self._room = room if self._room is None else AzimuthLikelihood(
            self._room.log_likelihood + room.log_likelihood, "room")
        self.estimates += 1
        if self._start is None:
            assert estimate.head_azimuth is not None
            self._start = estimate.head_azimuth
            # Turn towards the source's side first: the lateral side of the first estimate.
            self._side = 1.0 if math.sin(estimate.azimuth) >= 0 else -1.0

    @property
    def room(self) -> AzimuthLikelihood | None:
        """The combined room-frame likelihood (None before the first estimate)."""
        return self._room

    @property
    def settled(self) -> bool:
        """Whether enough has been heard: the confidence is reached after ``min_turns``, or ``max_turns`` are done."""
        turns = max(0, len(self.looks) - 1)
        if self._room is None:
            return False
        return turns >= self.max_turns or (turns >= self.min_turns and self._room.confidence() >= self.confidence)

    def looked(self, head_azimuth: float) -> None:
        """Record that the head looked from *head_azimuth* (degrees): the start, then each turn reached."""
        self.looks.append(float(head_azimuth))

    def next_look(self) -> float | None:
        """The head azimuth to look from next (degrees), or None when settled.

        Looks alternate either side of the start, ``turn`` degrees away, then twice as far, and
        so on, the source's side first; those the limits forbid are left out, so that no two
        looks ask for the same azimuth. When none is left within the limits, the head turns as
        far as they allow, alternately either way.
        """
        if self.settled or self._start is None:
            return None
        turns = max(0, len(self.looks) - 1)
        low, high = self.limits
        allowed = [target for step in range(1, self.max_turns + 1) for direction in (self._side, -self._side)
                   if low <= (target := self._start + direction * self.turn * step) <= high]
        if turns < len(allowed):
            return allowed[turns]
        side = self._side if (turns - len(allowed)) % 2 == 0 else -self._side
        return min(high, max(low, self._start + side * self.turn))

    def found(self) -> tuple[float, float]:
        """The source's room azimuth (degrees) and the posterior mass within ±10° of it.

        Raises:
            LocalisationError: before any estimate.
        """
        if self._room is None:
            raise LocalisationError("no estimate yet")
        peak = self._room.peak()
        return peak, self._room.mass_near(peak)

    def facing(self) -> float:
        """The head azimuth that faces the source, within the limits (degrees)."""
        azimuth, _ = self.found()
        low, high = self.limits
        return min(high, max(low, azimuth))
