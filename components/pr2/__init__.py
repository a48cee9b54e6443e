"""The ``pr2`` component: the seed's ``pr2_full`` (appendix 9.5.4), driving the PR2 of ``world``.

Each activity publishes its goal on its out port, as the seed's codels did for the Python script
that turned them into ROS action goals, and ends when the robot, seen on the world's joint states
and odometry, is there (within a tolerance) — not when the goal was sent.

The Two!Ears project mounted the KEMAR's binaural head on top of the PR2's head (seed section 8.1.4):
while ``pr2`` is loaded, a capture of the simulated scene hears the world's sound-source markers in the
world's room from that head, wherever the base drives, turning with the base's heading and the head's pan.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable
from typing import Annotated, Any

import numpy as np

from ..audio import HeadAzimuth, SoundScene
from ..core import (
    Component, Double, GenomException, InPort, InPortRuntime, OutPort, OutPortRuntime, String, Task, activity,
)
from ..world import (
    ARM_JOINTS, HEAD_LIMITS, ROOM, TORSO_RANGE, HeadCommand, Image, JointState, LeftArmCommand,
    Odometry, PositionCommand, RightArmCommand, TorsoCommand, arm_limits, attach, marker_scene,
)

__all__ = ["Pr2", "INVALID_TORSO", "INVALID_VALUE", "WIRING"]

#: The default wiring to ``world``: {pr2 port: world port}.
WIRING = {"Port_head": "pr2_head", "Port_gotoposition": "pr2_goal", "Port_l_arm": "pr2_l_arm",
          "Port_r_arm": "pr2_r_arm", "Port_torso": "pr2_torso", "Image": "pr2_video", "Odom": "pr2_odom",
          "JointStates": "pr2_joints"}

#: A joint is there within this distance (rad; m for the torso) ...
JOINT_TOLERANCE = 0.005
TORSO_TOLERANCE = 0.002
#: ... moving slower than this (rad/s; m/s for the torso).
JOINT_STILL = 0.02
TORSO_STILL = 0.005
#: The base is there within this distance (m) and heading (rad), moving slower than BASE_STILL (m/s, rad/s).
BASE_TOLERANCE = 0.005
HEADING_TOLERANCE = math.radians(0.25)
BASE_STILL = 0.02
#: Where the head pans, behind the base's centre in its frame (m): the torso lift link at -0.05 m
#: and the head pan link 0.017 m behind it, as in the world's model.
HEAD_PAN_X = -0.067
#: Height of the KEMAR head's ears on the PR2's head, the torso down (m): the head cameras' height
#: plus the binaural head mounted above them (seed 8.1.4).
KEMAR_HEAD_HEIGHT = 1.35


class INVALID_TORSO(GenomException):
    """The torso height is outside the lift's range (0 to 0.31 m), or not a number."""


class INVALID_VALUE(GenomException):
    """A parameter is not a number, is infinite, or is a base goal outside the room.

    ``parameter`` names it; ``value`` says what it was.
    """

    parameter: String
    value: String


def _finite(**values: float) -> None:
    for name, value in values.items():
        if not math.isfinite(value):
            raise INVALID_VALUE(parameter=name, value=repr(value))


def _clamp(value: float, lower: float | None, upper: float | None) -> float:
    if lower is not None:
        value = max(lower, value)
    if upper is not None:
        value = min(upper, value)
    return value


class Pr2(Component, name="pr2", version="1.0"):
    """The virtual PR2 (seed appendix 9.5.4, ``pr2_full``): head, base, arms and torso of the PR2 in ``world``.

    Loading it loads ``world`` if needed and connects the ports (``Port_*`` to the world's command in
    ports; ``Image``, ``Odom`` and ``JointStates`` to its camera, odometry and joint states).
    """

    exceptions = (INVALID_TORSO, INVALID_VALUE)

    PublishPort = Task(period=0.02, doc="Publishes the goals and follows the motions, every 20 ms")
    VideoCamera_RGBA = Task(period=0.049, doc="Receives the head camera's images, every 49 ms")

    Port_head = OutPort(HeadCommand, doc="The head goal: pan, tilt (rad) and time_to_finish (s)")
    Port_gotoposition = OutPort(PositionCommand, doc="The base goal: x, y (m) and w (rad) in the room")
    Port_l_arm = OutPort(LeftArmCommand, doc="The left arm goal: seven joints (rad) and time_to_finish (s)")
    Port_r_arm = OutPort(RightArmCommand, doc="The right arm goal: seven joints (rad) and time_to_finish (s)")
    Port_torso = OutPort(TorsoCommand, doc="The torso goal: lift (m) and time_to_finish (s)")
    Image = InPort(Image, doc="The head camera (world/pr2_video)")
    # Not in the seed's .gen: the ROS action feedback its Python script received, as ports.
    Odom = InPort(Odometry, doc="The base odometry (world/pr2_odom): go_to_position ends on it")
    JointStates = InPort(JointState, doc="The joint states (world/pr2_joints): the joint motions end on them")

    async def on_start(self) -> None:
        """Load the world if needed, wire the ports, and let the simulated scene hear from the head."""
        self.frames = 0
        await attach(self, WIRING)
        # The head is carried through the room by the base: where it is is read at every chunk.
        heard = SoundScene(marker_scene(self.ears()), listener=self.ears)
        self.provide(SoundScene, heard)
        self.provide(HeadAzimuth, HeadAzimuth(self.head_azimuth))

    # -- where the binaural head is ----------------------------------------------------------

    def _pan(self) -> float:
        state = self.JointStates.read()
        if state is None or "head_pan_joint" not in state.name:
            return 0.0
        return float(state.position[list(state.name).index("head_pan_joint")])

    def head_azimuth(self) -> float:
        """The head's azimuth in the room: the base's heading plus the head's pan (degrees, positive = left)."""
        odom = self.Odom.read()
        return math.degrees((odom.w if odom is not None else 0.0) + self._pan())

    def ears(self) -> tuple[float, float, float]:
        """Where the KEMAR head on the PR2's head is in the room: (x, y, z) in metres, the torso lift included."""
        x, y = self.head_position()
        state = self.JointStates.read()
        lift = 0.0
        if state is not None and "torso_lift_joint" in state.name:
            lift = float(state.position[list(state.name).index("torso_lift_joint")])
        return (x, y, KEMAR_HEAD_HEIGHT + lift)

    def head_position(self) -> tuple[float, float]:
        """Where the head pans in the room, (x, y) in metres, from the base's odometry."""
        odom = self.Odom.read()
        if odom is None:
            return HEAD_PAN_X, 0.0
        return odom.x + HEAD_PAN_X * math.cos(odom.w), odom.y + HEAD_PAN_X * math.sin(odom.w)

    # -- following the robot -----------------------------------------------------------------

    async def _until(self, port: InPortRuntime, arrived: Callable[[Any], bool]) -> None:
        """Wait until the data of *port* (an in port) satisfies *arrived*."""
        while True:
            remote = port.remote
            if remote is None:
                await self.PublishPort.tick()  # unconnected: wait for connect_port
                continue
            version = remote.version
            if arrived(port.read()):
                return
            await remote.wait_published(version)

    async def _move_joints(self, goals: dict[str, float], tolerance: float, still: float) -> None:
        def arrived(state: JointState) -> bool:
            names = list(state.name)
            if not all(joint in names for joint in goals):
                return False
            position, velocity = np.asarray(state.position), np.asarray(state.velocity)
            return all(abs(position[names.index(j)] - goal) <= tolerance and abs(velocity[names.index(j)]) <= still
                       for j, goal in goals.items())

        try:
            await self._until(self.JointStates, arrived)
        except asyncio.CancelledError:
            self._hold(goals)
            raise

    def _hold(self, joints: dict[str, float]) -> None:
        """Stop path: ask the joints to stay where they are now."""
        state = self.JointStates.read()
        if state is None:
            return
        names = list(state.name)
        here = {j: float(state.position[names.index(j)]) for j in joints if j in names}
        if "head_pan_joint" in here:
            self.Port_head.publish(HeadCommand(here["head_pan_joint"], here.get("head_tilt_joint", 0.0), 0.0))
        if "torso_lift_joint" in here:
            self.Port_torso.publish(TorsoCommand(here["torso_lift_joint"], 0.0))
        arms: tuple[tuple[str, OutPortRuntime[Any], type[Any]], ...] = (
            ("l", self.Port_l_arm, LeftArmCommand), ("r", self.Port_r_arm, RightArmCommand))
        for side, port, command in arms:
            if f"{side}_shoulder_pan_joint" in here:
                port.publish(command(*(here[f"{side}_{j}"] for j in ARM_JOINTS), 0.0))

    # -- validation ----------------------------------------------------------------------------

    def controlTorso(self, torso: float, time_to_finish: float) -> None:  # noqa: N802 - the seed's codel name
        """Refuse a torso height outside the lift's range (the seed's ``validate controlTorso``)."""
        if not (math.isfinite(torso) and TORSO_RANGE[0] <= torso <= TORSO_RANGE[1]):
            raise INVALID_TORSO()
        _finite(time_to_finish=time_to_finish)

    def _validate_head(self, pan: float, tilt: float, time_to_finish: float) -> None:
        _finite(pan=pan, tilt=tilt, time_to_finish=time_to_finish)

    def _validate_position(self, x: float, y: float, w: float) -> None:
        _finite(x=x, y=y, w=w)
        x0, x1, y0, y1 = ROOM
        if not x0 <= x <= x1:
            raise INVALID_VALUE(parameter="x", value=f"{x!r} is outside the room ({x0} to {x1} m)")
        if not y0 <= y <= y1:
            raise INVALID_VALUE(parameter="y", value=f"{y!r} is outside the room ({y0} to {y1} m)")

    # -- services --------------------------------------------------------------------------------

    @activity(task=PublishPort, interrupts=("move_head",), throws=(INVALID_VALUE,), validate=_validate_head,
              motion=True)
    async def move_head(
        self,
        pan: Annotated[Double, "Head pan in rad (positive = left, -2.857 to 2.857)"] = 0.0,
        tilt: Annotated[Double, "Head tilt in rad (positive = down, -0.371 to 1.296)"] = 0.0,
        time_to_finish: Annotated[Double, "Seconds the motion should take"] = 1.0,
    ) -> None:
        """Turn the head to a pan and tilt, and wait until it is there (goals outside the limits stop at them)."""
        self.Port_head.publish(HeadCommand(pan, tilt, time_to_finish))
        goals = {name: _clamp(value, *HEAD_LIMITS[name][:2])
                 for name, value in (("head_pan_joint", pan), ("head_tilt_joint", tilt))}
        await self._move_joints(goals, JOINT_TOLERANCE, JOINT_STILL)

    @activity(task=PublishPort, interrupts=("go_to_position",), throws=(INVALID_VALUE,),
              validate=_validate_position, motion=True)
    async def go_to_position(
        self,
        x: Annotated[Double, "x in the room, m"] = 0.0,
        y: Annotated[Double, "y in the room, m"] = 0.0,
        w: Annotated[Double, "Heading in rad, counter-clockwise from x"] = 0.0,
    ) -> None:
        """Drive the base to a pose of the room and wait until it is there (a new goal interrupts the last)."""
        self.Port_gotoposition.publish(PositionCommand(x, y, w))

        def arrived(odom: Odometry) -> bool:
            heading = abs(math.remainder(odom.w - w, 2 * math.pi))
            return (math.hypot(odom.x - x, odom.y - y) <= BASE_TOLERANCE and heading <= HEADING_TOLERANCE
                    and math.hypot(odom.vx, odom.vy) <= BASE_STILL and abs(odom.vw) <= BASE_STILL)

        try:
            await self._until(self.Odom, arrived)
        except asyncio.CancelledError:
            odom = self.Odom.read()
            if odom is not None:  # stop path: stay here
                self.Port_gotoposition.publish(PositionCommand(odom.x, odom.y, odom.w))
            raise

    async def _move_arm(self, side: str, values: tuple[float, ...], time_to_finish: float) -> None:
        """Publish the goal of arm *side* (its seven joints in order) and wait until the arm is there."""
        joints = {f"{side}_{j}": v for j, v in zip(ARM_JOINTS, values, strict=True)}
        _finite(**joints, time_to_finish=time_to_finish)
        limits = arm_limits(side)
        goals = {name: _clamp(value, *limits[name][:2]) for name, value in joints.items()}
        if side == "l":
            self.Port_l_arm.publish(LeftArmCommand(**joints, time_to_finish=time_to_finish))
        else:
            self.Port_r_arm.publish(RightArmCommand(**joints, time_to_finish=time_to_finish))
        await self._move_joints(goals, JOINT_TOLERANCE, JOINT_STILL)

    @activity(motion=True, task=PublishPort, interrupts=("move_l_arm",), throws=(INVALID_VALUE,))
    async def move_l_arm(
        self,
        l_shoulder_pan_joint: Annotated[Double, "rad, -0.715 to 2.285"] = 0.0,
        l_shoulder_lift_joint: Annotated[Double, "rad, -0.524 to 1.396"] = 0.0,
        l_upper_arm_roll_joint: Annotated[Double, "rad, -0.8 to 3.9"] = 0.0,
        l_elbow_flex_joint: Annotated[Double, "rad, -2.321 to 0"] = 0.0,
        l_forearm_roll_joint: Annotated[Double, "rad, continuous"] = 0.0,
        l_wrist_flex_joint: Annotated[Double, "rad, -2.18 to 0"] = 0.0,
        l_wrist_roll_joint: Annotated[Double, "rad, continuous"] = 0.0,
        time_to_finish: Annotated[Double, "Seconds the motion should take"] = 1.0,
    ) -> None:
        """Move the left arm's seven joints and wait until they are there (goals outside the limits stop at them)."""
        values = (l_shoulder_pan_joint, l_shoulder_lift_joint, l_upper_arm_roll_joint, l_elbow_flex_joint,
                  l_forearm_roll_joint, l_wrist_flex_joint, l_wrist_roll_joint)
        await self._move_arm("l", values, time_to_finish)

    @activity(motion=True, task=PublishPort, interrupts=("move_r_arm",), throws=(INVALID_VALUE,))
    async def move_r_arm(
        self,
        r_shoulder_pan_joint: Annotated[Double, "rad, -2.285 to 0.715"] = 0.0,
        r_shoulder_lift_joint: Annotated[Double, "rad, -0.524 to 1.396"] = 0.0,
        r_upper_arm_roll_joint: Annotated[Double, "rad, -3.9 to 0.8"] = 0.0,
        r_elbow_flex_joint: Annotated[Double, "rad, -2.321 to 0"] = 0.0,
        r_forearm_roll_joint: Annotated[Double, "rad, continuous"] = 0.0,
        r_wrist_flex_joint: Annotated[Double, "rad, -2.18 to 0"] = 0.0,
        r_wrist_roll_joint: Annotated[Double, "rad, continuous"] = 0.0,
        time_to_finish: Annotated[Double, "Seconds the motion should take"] = 1.0,
    ) -> None:
        """Move the right arm's seven joints and wait until they are there (goals outside the limits stop at them)."""
        values = (r_shoulder_pan_joint, r_shoulder_lift_joint, r_upper_arm_roll_joint, r_elbow_flex_joint,
                  r_forearm_roll_joint, r_wrist_flex_joint, r_wrist_roll_joint)
        await self._move_arm("r", values, time_to_finish)

    @activity(motion=True, task=PublishPort, interrupts=("move_torso",), throws=(INVALID_TORSO, INVALID_VALUE),
              validate=controlTorso)
    async def move_torso(
        self,
        torso: Annotated[Double, "Torso lift in m, 0 to 0.31"] = 0.0,
        time_to_finish: Annotated[Double, "Seconds the motion should take"] = 1.0,
    ) -> None:
        """Raise or lower the torso and wait until it is there."""
        self.Port_torso.publish(TorsoCommand(torso, time_to_finish))
        await self._move_joints({"torso_lift_joint": torso}, TORSO_TOLERANCE, TORSO_STILL)

    @activity(task=VideoCamera_RGBA)
    async def receive_image(self) -> None:
        """Receive the head camera's images, one per 49 ms, until interrupted (``frames`` counts them)."""
        seen = None
        while True:
            image = self.Image.read()
            if image is not None and image is not seen:
                seen, self.frames = image, self.frames + 1
            await self.VideoCamera_RGBA.tick()
