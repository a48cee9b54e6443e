"""The IDL types of the virtual robots' ports: MORSE's ROS messages and the ``pr2_full`` command structs.

The type names are those of the seed's ``.gen`` files (``subscriber::sensor_msgs__Image``...), so a
``pr2`` or ``morse_kemar`` in port connects to the matching ``world`` out port, as GenoM3 met MORSE on
ROS topics.
"""

from __future__ import annotations

import dataclasses
from typing import Annotated

import numpy as np
from numpy.typing import NDArray

from .. import core
from ..core import Double, Float, Image as ImageKind, JointStates, LaserScan as ScanKind, Odometry as OdometryKind
from ..core import Pose as PoseKind, String, ULong, Unit, idl_struct

__all__ = [
    "Timestamp", "Header", "Image", "Odometry", "JointState", "LaserScan", "Point", "Quaternion", "Pose",
    "PoseStamped", "Vector3", "Twist", "HeadCommand", "PositionCommand", "LeftArmCommand", "RightArmCommand",
    "TorsoCommand", "ARM_JOINTS",
]

#: The seven joints of a PR2 arm, shoulder to wrist, without the ``l_``/``r_`` prefix.
ARM_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "upper_arm_roll_joint", "elbow_flex_joint",
              "forearm_roll_joint", "wrist_flex_joint", "wrist_roll_joint")


@idl_struct("subscriber::time")
class Timestamp(core.Timestamp):
    """A simulation time (runtime clock) split into seconds and nanoseconds."""


@idl_struct("subscriber::std_msgs__Header")
class Header:
    """When the data was taken (runtime clock) and in which frame."""

    seq: ULong = 0
    stamp: Timestamp = dataclasses.field(default_factory=Timestamp)
    frame_id: String = ""


@idl_struct("subscriber::sensor_msgs__Image", carries=ImageKind())
class Image:
    """A camera frame: ``height`` rows of ``step`` octets, ``encoding`` ``"rgba8"`` (R, G, B, A per pixel).

    ``data`` holds ``width * height * 4`` octets (262,144 for the seed's 256×256 cameras), top row first.
    """

    width: ULong = 0
    height: ULong = 0
    encoding: String = "rgba8"
    step: ULong = 0
    data: NDArray[np.uint8] = dataclasses.field(default_factory=lambda: np.zeros(0, np.uint8))

    def pixels(self) -> np.ndarray:
        """The frame as a ``(height, width, 4)`` array of octets (a view of ``data``)."""
        return np.asarray(self.data, dtype=np.uint8).reshape(int(self.height), int(self.width), 4)


# The room's velocity (vx, vy along the room's axes), as the seed's world gave it.
@idl_struct("world::odometry", carries=OdometryKind(x="x", y="y", yaw="w", vx="vx", vy="vy", turn="vw",
                                                    velocity_frame="room"))
class Odometry:
    """The PR2 base in the room: position (m), heading ``w`` (rad, counter-clockwise from x) and speeds."""

    x: Annotated[Double, Unit("m")] = 0.0
    y: Annotated[Double, Unit("m")] = 0.0
    w: Annotated[Double, Unit("rad"), "Heading, counter-clockwise from x"] = 0.0
    vx: Annotated[Double, Unit("m/s")] = 0.0
    vy: Annotated[Double, Unit("m/s")] = 0.0
    vw: Annotated[Double, Unit("rad/s")] = 0.0
    stamp: Timestamp = dataclasses.field(default_factory=Timestamp)


@idl_struct("subscriber::sensor_msgs__JointState", carries=JointStates())
class JointState:
    """Joint names with their positions (rad, or m for the torso) and speeds, in the same order."""

    header: Header = dataclasses.field(default_factory=Header)
    name: list[String] = dataclasses.field(default_factory=list)
    position: NDArray[np.float64] = dataclasses.field(default_factory=lambda: np.zeros(0))
    velocity: NDArray[np.float64] = dataclasses.field(default_factory=lambda: np.zeros(0))


@idl_struct("subscriber::sensor_msgs__LaserScan", carries=ScanKind())
class LaserScan:
    """One sweep of the base laser: ranges (m) from ``angle_min`` to ``angle_max`` (rad, 0 = ahead, + = left).

    A beam that hits nothing within ``range_max`` reads ``range_max``.
    """

    header: Header = dataclasses.field(default_factory=Header)
    angle_min: Annotated[Float, Unit("rad")] = 0.0
    angle_max: Annotated[Float, Unit("rad")] = 0.0
    angle_increment: Annotated[Float, Unit("rad")] = 0.0
    range_min: Annotated[Float, Unit("m")] = 0.0
    range_max: Annotated[Float, Unit("m")] = 0.0
    ranges: NDArray[np.float32] = dataclasses.field(default_factory=lambda: np.zeros(0, np.float32))


@idl_struct("subscriber::geometry_msgs__Point")
class Point:
    """A position in metres."""

    x: Annotated[Double, Unit("m")] = 0.0
    y: Annotated[Double, Unit("m")] = 0.0
    z: Annotated[Double, Unit("m")] = 0.0


@idl_struct("subscriber::geometry_msgs__Quaternion")
class Quaternion:
    """An orientation as a unit quaternion."""

    x: Double = 0.0
    y: Double = 0.0
    z: Double = 0.0
    w: Double = 1.0


@idl_struct("subscriber::geometry_msgs__Pose")
class Pose:
    """A position and an orientation."""

    position: Point = dataclasses.field(default_factory=Point)
    orientation: Quaternion = dataclasses.field(default_factory=Quaternion)


@idl_struct("subscriber::geometry_msgs__PoseStamped", carries=PoseKind())
class PoseStamped:
    """A pose in the room, stamped."""

    header: Header = dataclasses.field(default_factory=Header)
    pose: Pose = dataclasses.field(default_factory=Pose)


@idl_struct("subscriber::geometry_msgs__Vector3")
class Vector3:
    """Three components."""

    x: Double = 0.0
    y: Double = 0.0
    z: Double = 0.0


@idl_struct("subscriber::geometry_msgs__Twist")
class Twist:
    """A velocity command in the robot's frame: ``linear`` in m/s, ``angular`` in rad/s (ROS units)."""

    linear: Vector3 = dataclasses.field(default_factory=Vector3)
    angular: Vector3 = dataclasses.field(default_factory=Vector3)


@idl_struct("subscriber::head")
class HeadCommand:
    """A head goal: pan and tilt (rad), reached in ``time_to_finish`` s."""

    pan: Double = 0.0
    tilt: Double = 0.0
    time_to_finish: Double = 0.0


@idl_struct("subscriber::position")
class PositionCommand:
    """A base goal in the room: x, y (m) and heading w (rad)."""

    x: Double = 0.0
    y: Double = 0.0
    w: Double = 0.0


@idl_struct("subscriber::l_arm")
class LeftArmCommand:
    """A left-arm goal: the seven joints (rad), reached in ``time_to_finish`` s."""

    l_shoulder_pan_joint: Double = 0.0
    l_shoulder_lift_joint: Double = 0.0
    l_upper_arm_roll_joint: Double = 0.0
    l_elbow_flex_joint: Double = 0.0
    l_forearm_roll_joint: Double = 0.0
    l_wrist_flex_joint: Double = 0.0
    l_wrist_roll_joint: Double = 0.0
    time_to_finish: Double = 0.0


@idl_struct("subscriber::r_arm")
class RightArmCommand:
    """A right-arm goal: the seven joints (rad), reached in ``time_to_finish`` s."""

    r_shoulder_pan_joint: Double = 0.0
    r_shoulder_lift_joint: Double = 0.0
    r_upper_arm_roll_joint: Double = 0.0
    r_elbow_flex_joint: Double = 0.0
    r_forearm_roll_joint: Double = 0.0
    r_wrist_flex_joint: Double = 0.0
    r_wrist_roll_joint: Double = 0.0
    time_to_finish: Double = 0.0


@idl_struct("subscriber::torso")
class TorsoCommand:
    """A torso goal: the lift (m, 0 to 0.31), reached in ``time_to_finish`` s."""

    torso: Double = 0.0
    time_to_finish: Double = 0.0
