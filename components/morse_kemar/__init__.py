"""The ``morse_kemar`` component: the seed's virtual KEMAR (appendix 9.5.5), turning the KEMAR head of ``world``.

As in the seed, it writes speed commands on ``RobotMotion`` (a Twist, angular.z in rad/s) and reads the
head's pose on ``RobotPose``; its services take degrees and deg/s, positive to the left, like ``kemar``.
While it is loaded, a capture of the simulated scene hears the world's sound-source markers in the world's
room (its walls' reflections and reverberation), from where its KEMAR stands, turning with its head (it
provides the host's ``HeadAzimuth`` and ``SoundScene``), and active listening may turn its head (it
provides a ``TurnableHead``).
"""

from __future__ import annotations

import math
from typing import Annotated

from ..audio import HeadAzimuth, SoundScene
from ..binaural import TurnableHead
from ..core import Component, Double, GenomException, InPort, OutPort, String, Task, activity
from ..world import (
    KEMAR_EAR_HEIGHT, KEMAR_LIMIT, KEMAR_ORIGIN, Image, PoseStamped, Twist, Vector3, attach, marker_scene,
)

__all__ = ["MorseKemar", "INVALID_VALUE", "WIRING", "yaw_of"]

#: The default wiring to ``world``: {morse_kemar port: world port}.
WIRING = {"CameraL": "kemar_camera_left", "CameraR": "kemar_camera_right", "RobotPose": "kemar_pose",
          "RobotMotion": "kemar_motion"}

#: The services that turn the head; each interrupts the others.
MOTIONS = ("Rotate", "MoveAbsolutePosition", "MoveRelativePosition", "ControlInSpeed")
#: Position moves end within this many degrees of the target...
TOLERANCE = 0.1
#: ... and slow down this many times per second of error near it (deg/s per degree).
GAIN = 10.0
#: Targets are kept this many degrees inside the limits, and speed control stops this far from them (as kemar).
LIMIT_MARGIN = 0.5
SPEED_MARGIN = 3.0
#: The fastest the neck turns, deg/s (the kemar drive's top speed).
MAX_SPEED = 900.0


class INVALID_VALUE(GenomException):
    """A parameter is not a number, is infinite, or a speed is out of range (``parameter``, ``value``)."""

    parameter: String
    value: String


def yaw_of(pose: PoseStamped) -> float:
    """The head azimuth of *pose* in degrees (positive = left)."""
    q = pose.pose.orientation
    return math.degrees(math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z)))


def _twist(deg_per_s: float) -> Twist:
    return Twist(Vector3(), Vector3(0.0, 0.0, math.radians(deg_per_s)))


def _finite(**values: float) -> None:
    for name, value in values.items():
        if not math.isfinite(value):
            raise INVALID_VALUE(parameter=name, value=repr(value))


def _speed(velocity: float, *, name: str = "velocity", zero: bool = False) -> None:
    _finite(**{name: velocity})
    if abs(velocity) > MAX_SPEED or (velocity == 0 and not zero):
        bounds = f"|{name}| <= {MAX_SPEED}" if zero else f"0 < |{name}| <= {MAX_SPEED}"
        raise INVALID_VALUE(parameter=name, value=f"{velocity!r} deg/s ({bounds})")


class MorseKemar(Component, name="morse_kemar", version="1.0"):
    """The virtual KEMAR head-and-torso (seed appendix 9.5.5): its neck turns the eye cameras in ``world``.

    Loading it loads ``world`` if needed and connects ``CameraL``, ``CameraR``, ``RobotPose`` and
    ``RobotMotion`` there.  Angles in degrees, positive to the left; limits ±90° as the motorised KEMAR.
    """

    exceptions = (INVALID_VALUE,)

    ReceiveImage = Task(period=0.02, doc="Receives the eye cameras' images, every 20 ms")
    Motion = Task(period=0.02, doc="Sends the speed commands of the motions, every 20 ms")
    Position = Task(period=0.001, doc="Reads the head position (the seed's InitPosition; here read on demand)")

    CameraL = InPort(Image, doc="The left eye camera (world/kemar_camera_left)")
    CameraR = InPort(Image, doc="The right eye camera (world/kemar_camera_right)")
    RobotPose = InPort(PoseStamped, doc="The head pose (world/kemar_pose)")
    RobotMotion = OutPort(Twist, doc="The neck speed command: angular.z in rad/s, positive = left")

    async def on_start(self) -> None:
        """Load the world if needed, wire the ports, and read where the head is."""
        #: The ids of the seed: the head azimuth in degrees, as last read from RobotPose.
        self.currentPosition = 0.0
        self.frames = 0
        await attach(self, WIRING)
        self._read_position()
        # The simulated sound scene hears the world's markers in the world's room and turns with this head.
        self.provide(SoundScene, SoundScene(marker_scene((*KEMAR_ORIGIN, KEMAR_EAR_HEIGHT))))
        self.provide(HeadAzimuth, HeadAzimuth(self._pose_azimuth))
        # Active listening (binauloc's FaceSource) turns this head through MoveAbsolutePosition.
        limit = math.degrees(KEMAR_LIMIT) - LIMIT_MARGIN
        self.provide(TurnableHead, TurnableHead.by_service(self, self._azimuth_now, (-limit, limit)))

    async def _azimuth_now(self) -> float:
        return self._pose_azimuth()

    def _pose_azimuth(self) -> float:
        """The head azimuth of the newest RobotPose (degrees, positive = left), without touching currentPosition."""
        pose = self.RobotPose.read()
        return yaw_of(pose) if pose is not None else self.currentPosition

    def _read_position(self) -> float:
        pose = self.RobotPose.read()
        if pose is not None:
            self.currentPosition = yaw_of(pose)
        return self.currentPosition

    async def _next_pose(self) -> float:
        remote = self.RobotPose.remote
        if remote is None:
            await self.Motion.tick()
        else:
            await remote.wait_published()
        return self._read_position()

    # -- validation --------------------------------------------------------------------------

    def _validate_move(self, target: float, velocity: float) -> None:
        _finite(target=target)
        _speed(velocity)

    def _validate_speed(self, velocity: float) -> None:
        _speed(velocity, zero=True)

    def _validate_rotate(self, z: float) -> None:
        _speed(z, name="z", zero=True)

    # -- services ------------------------------------------------------------------------------

    @activity(task=ReceiveImage, interrupts=("Receive",))
    async def Receive(self) -> None:
        """Receive both eye cameras' images, every 20 ms, until interrupted (``frames`` counts the pairs)."""
        seen = None
        while True:
            pair = (self.CameraL.read(), self.CameraR.read())
            if pair[0] is not None and (seen is None or pair[0] is not seen[0]):
                seen, self.frames = pair, self.frames + 1
            await self.ReceiveImage.tick()

    @activity(motion=True, task=Motion, interrupts=MOTIONS, throws=(INVALID_VALUE,), validate=_validate_rotate)
    async def Rotate(self, z: Annotated[Double, "Angular speed in deg/s (positive = left); 0 stops"] = 0.0) -> None:
        """Send one speed command: the head turns at *z* deg/s until told otherwise or a limit stops it."""
        self.RobotMotion.publish(_twist(z))

    async def stop_motions(self) -> None:
        """Stop the head a Rotate left turning (the dead-man switch of a remote host calls it)."""
        if self.RobotMotion.read().angular.z != 0.0:
            self.RobotMotion.publish(_twist(0.0))

    async def _go(self, target: float, velocity: float) -> None:
        """Turn to *target* degrees (kept inside the limits) at up to *velocity* deg/s."""
        limit = math.degrees(KEMAR_LIMIT) - LIMIT_MARGIN
        target = max(-limit, min(limit, target))
        speed = abs(velocity)
        try:
            position = self._read_position()
            while abs(target - position) > TOLERANCE:
                error = target - position
                self.RobotMotion.publish(_twist(math.copysign(min(speed, GAIN * abs(error)), error)))
                await self.Motion.tick()
                position = self._read_position()
        finally:
            self.RobotMotion.publish(_twist(0.0))  # stop path, whatever ended the move

    @activity(motion=True, task=Motion, interrupts=MOTIONS, throws=(INVALID_VALUE,), validate=_validate_move)
    async def MoveAbsolutePosition(
        self,
        target: Annotated[Double, "Azimuth in degrees (positive = left), kept 0.5 deg inside ±90"] = 0.0,
        velocity: Annotated[Double, "Speed in deg/s"] = 100.0,
    ) -> None:
        """Turn the head to an azimuth and wait until it is there."""
        await self._go(target, velocity)

    @activity(motion=True, task=Motion, interrupts=MOTIONS, throws=(INVALID_VALUE,), validate=_validate_move)
    async def MoveRelativePosition(
        self,
        target: Annotated[Double, "Degrees to turn from the present azimuth (positive = left)"] = 0.0,
        velocity: Annotated[Double, "Speed in deg/s"] = 100.0,
    ) -> None:
        """Turn the head by an angle from where it is (the final azimuth is kept inside the limits)."""
        await self._go(self._read_position() + target, velocity)

    @activity(motion=True, task=Motion, interrupts=MOTIONS, throws=(INVALID_VALUE,), validate=_validate_speed)
    async def ControlInSpeed(
        self, velocity: Annotated[Double, "Angular speed in deg/s (positive = left); 0 stops the head"] = 0.0
    ) -> None:
        """Turn the head at a constant speed until 0 is asked or it comes 3 degrees from a limit."""
        stop_at = math.degrees(KEMAR_LIMIT) - SPEED_MARGIN
        if velocity == 0:
            self.RobotMotion.publish(_twist(0.0))
            return
        try:
            self.RobotMotion.publish(_twist(velocity))
            while math.copysign(1, velocity) * self._read_position() < stop_at:
                await self._next_pose()
        finally:
            self.RobotMotion.publish(_twist(0.0))
