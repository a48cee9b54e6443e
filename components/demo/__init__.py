"""The GenoM3 ``demo`` component: a virtual robot that moves on a line (seed report, section 4.3.3)."""

from __future__ import annotations

import enum
import math
from typing import Annotated

from ..core import (
    Component, Double, GenomException, OutPort, Out, String, Task, activity, attribute, function, idl_enum,
    idl_struct, Unit,
)

__all__ = ["Demo", "Speed", "State", "TOO_FAR_AWAY", "INVALID_VALUE", "TRACK_END", "SPEEDS"]

#: The track runs from -TRACK_END to +TRACK_END metres.
TRACK_END = 1.0


@idl_enum("demo::speed")
class Speed(enum.Enum):
    """The three speeds of the robot."""

    SLOW = 0
    MEDIUM = 1
    FAST = 2


#: Metres per second of each speed.
SPEEDS = {Speed.SLOW: 0.1, Speed.MEDIUM: 0.2, Speed.FAST: 0.4}


@idl_struct("demo::state")
class State:
    """Where the robot is and how fast it goes."""

    position: Annotated[Double, Unit("m"), "Position on the track"] = 0.0
    speed: Annotated[Double, Unit("m/s"), "Speed along the track"] = 0.0


class TOO_FAR_AWAY(GenomException):
    """The target lies outside the track; ``overshoot`` says by how many metres."""

    overshoot: Double


class INVALID_VALUE(GenomException):
    """A parameter is not a number (NaN: JSON null decodes to it) or is infinite.

    ``parameter`` names it; ``value`` is ``"nan"``, ``"inf"`` or ``"-inf"``.
    """

    parameter: String
    value: String


def _refuse_non_finite(parameter: str, value: float) -> None:
    # A double accepts NaN and infinities, but no robot goes there: say so, rather than let a
    # comparison with NaN fail somewhere downstream and report a misleading exception.
    if not math.isfinite(value):
        raise INVALID_VALUE(parameter=parameter, value=repr(value))


def _refuse_off_track(position: float) -> None:
    if abs(position) > TRACK_END:
        raise TOO_FAR_AWAY(overshoot=abs(position) - TRACK_END)


class Demo(Component, name="demo", version="1.1"):
    """A virtual mobile robot on a line from -1 m to +1 m, moving at a chosen speed."""

    motion = Task(period=0.05, doc="Moves the robot, 20 times per second")
    Mobile = OutPort(State, doc="The position (m) and speed (m/s) of the robot")

    async def on_start(self) -> None:
        """Stand still at the middle of the track, at the slow speed."""
        self.speed_ref = Speed.SLOW
        self.state = State()
        self.Mobile.publish(self.state)

    def _validate_goto(self, posRef: float) -> None:
        _refuse_non_finite("posRef", posRef)
        _refuse_off_track(posRef)

    def _validate_move(self, distRef: float) -> None:
        _refuse_non_finite("distRef", distRef)
        _refuse_off_track(self.state.position + distRef)

    def _validate_monitor(self, monitor: float) -> None:
        # A NaN position is never reached nor crossed: the request would wait forever.
        _refuse_non_finite("monitor", monitor)

    async def _drive_to(self, target: float) -> None:
        """Move at the reference speed, one step per task period, until *target* is reached."""
        try:
            while self.state.position != target:
                await self.motion.tick()
                step = SPEEDS[self.speed_ref] * (self.motion.period or 0.0)
                distance = target - self.state.position
                if abs(distance) <= step:
                    self.state = State(position=target, speed=0.0)
                else:
                    direction = 1.0 if distance > 0 else -1.0
                    self.state = State(self.state.position + direction * step, direction * SPEEDS[self.speed_ref])
                self.Mobile.publish(self.state)
        finally:
            # Stop path: whatever ended the motion, the robot is left standing still.
            if self.state.speed != 0.0:
                self.state = State(self.state.position, 0.0)
                self.Mobile.publish(self.state)

    @activity(task=motion, interrupts=("GotoPosition", "MoveDistance"), throws=(TOO_FAR_AWAY, INVALID_VALUE),
              validate=_validate_goto, motion=True, progress="Mobile.position")
    async def GotoPosition(self, posRef: Annotated[Double, Unit("m"), "Goto position in m"] = 0.0) -> None:
        """Move the robot to an absolute position on the track."""
        await self._drive_to(posRef)

    @activity(task=motion, interrupts=("GotoPosition", "MoveDistance"), throws=(TOO_FAR_AWAY, INVALID_VALUE),
              validate=_validate_move, motion=True, progress="Mobile.position")
    async def MoveDistance(self, distRef: Annotated[Double, Unit("m"), "Distance in m"] = 0.0) -> None:
        """Move the robot by a distance from where it is."""
        await self._drive_to(self.state.position + distRef)

    @function(interrupts=("GotoPosition", "MoveDistance"))
    def Stop(self) -> None:
        """Stop the robot, interrupting any motion."""

    @attribute
    def SetSpeed(self, speedRef: Annotated[Speed, "Mobile speed"] = Speed.SLOW) -> None:
        """Set the speed of the next motions."""
        self.speed_ref = speedRef

    @attribute
    def GetSpeed(self) -> Annotated[Speed, Out("speedRef", "Mobile speed")]:
        """Get the speed of the motions."""
        return self.speed_ref

    @activity(task=motion, throws=(INVALID_VALUE,), validate=_validate_monitor, progress="Mobile.position")
    async def Monitor(
        self, monitor: Annotated[Double, Unit("m"), "Position to watch in m"] = 0.0
    ) -> Annotated[State, Out("state", "The state of the robot when it crossed the position")]:
        """Wait until the robot reaches or crosses a position, and report its state then."""
        side = self.state.position - monitor
        while True:
            state = self.state
            if state.position == monitor or (state.position - monitor) * side < 0:
                return state
            await self.Mobile.wait_published()
