"""The IDL types and declared exceptions of the kemar component (seed appendix 9.5.2 and 9.5.3)."""

from __future__ import annotations

import dataclasses

from .. import core
from typing import Annotated

from ..core import Boolean, Double, GenomException, HeadState, Long, String, Unit, idl_struct

__all__ = [
    "Timestamp",
    "KemarState",
    "MoveOutcome",
    "NOT_HOMED",
    "INVALID_TARGET",
    "INVALID_VELOCITY",
    "DRIVE_FAULT",
    "BUS_TIMEOUT",
    "BUS_ERROR",
    "DRIVE_ERROR",
    "HOMING_FAILED",
    "MOTION_STOPPED",
]


@idl_struct("kemar::timestamp_t")
class Timestamp(core.Timestamp):
    """A POSIX time split into seconds and nanoseconds."""


@idl_struct("kemar::state", carries=HeadState(position="position", velocity="speed"))
class KemarState:
    """The head: azimuth (deg, positive = left), speed (deg/s), the limits found by Homing (deg), and when."""

    position: Annotated[Double, Unit("deg"), "Head azimuth in degrees (positive = left)"] = 0.0
    speed: Annotated[Double, Unit("deg/s"), "Angular speed in deg/s (positive = left)"] = 0.0
    maxLeft: Annotated[Double, Unit("deg"), "Left limit found by Homing, degrees (0 before Homing)"] = 0.0
    maxRight: Annotated[Double, Unit("deg"), "Right limit found by Homing, degrees (0 before Homing)"] = 0.0
    timestamp: Annotated[Timestamp, "When the drive was read"] = dataclasses.field(default_factory=Timestamp)


@dataclasses.dataclass
class MoveOutcome:
    """The outputs of a position move: where the head stopped, and whether a limit stopped it short.

    An addition to the seed's interface, which ends such a move ``done`` at the limit with no
    sign that the target was out of reach.
    """

    position: Annotated[Double, Unit("deg"), "Azimuth reached, in degrees (positive = left)"] = 0.0
    limited: Annotated[Boolean, "The target was beyond a limit: the head stopped half a degree inside it"] = False


class NOT_HOMED(GenomException):
    """The head has no reference yet: call Homing before moving it."""

    message: String


class INVALID_TARGET(GenomException):
    """A target azimuth that is not a number (NaN or infinite); finite targets beyond a limit are clamped."""

    target: Double


class INVALID_VELOCITY(GenomException):
    """A speed is negative, zero where a speed is needed, or above the drive's maximum (deg/s)."""

    velocity: Double
    maximum: Double


class DRIVE_FAULT(GenomException):
    """The drive latched a motor fault or sent an emergency; the motor is off until the next Homing."""

    message: String


class BUS_TIMEOUT(GenomException):
    """The drive did not answer on the CAN bus (unpowered, unplugged or not started)."""

    message: String


class BUS_ERROR(GenomException):
    """The CAN bus could not be opened or refused a frame."""

    message: String


class DRIVE_ERROR(GenomException):
    """The drive refused a command; ``code`` is its Elmo error code (EC)."""

    message: String
    code: Long


class HOMING_FAILED(GenomException):
    """Homing did not find both limit switches or could not centre the head."""

    message: String


class MOTION_STOPPED(GenomException):
    """The head stopped away from its target (a limit switch, the drive, or a time-out)."""

    message: String
