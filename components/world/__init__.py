"""The virtual robots' world (seed chapter 7): a MuJoCo room with a PR2 and a KEMAR, cameras and a laser.

``world`` owns the simulation; ``pr2`` and ``morse_kemar`` (their own packages) drive the robots
through its ports.  MuJoCo is imported when a world is made, not when this package is.
"""

from ._component import CAMERA_PORTS, SENSOR_DOWN, World, parse_size, render_memory
from ._wiring import WORLD_INSTANCE, attach
from ._mjcf import (
    arm_limits, ARM_LIMITS, HEAD_LIMITS, KEMAR_EAR_HEIGHT, KEMAR_LIMIT, KEMAR_ORIGIN, OBJECTS, ROOM, SOUND_SOURCES,
    TORSO_RANGE, WALL_HEIGHT,
)
from ._sound import WORLD_ROOM, marker_azimuths, marker_scene
from ._types import (
    ARM_JOINTS, Header, HeadCommand, Image, JointState, LaserScan, LeftArmCommand, Odometry, Point, Pose,
    PoseStamped, PositionCommand, Quaternion, RightArmCommand, Timestamp, TorsoCommand, Twist, Vector3,
)

__all__ = [
    "World", "parse_size", "render_memory", "SENSOR_DOWN", "attach", "WORLD_INSTANCE", "marker_scene",
    "marker_azimuths", "WORLD_ROOM", "WALL_HEIGHT", "KEMAR_EAR_HEIGHT",
    "CAMERA_PORTS", "arm_limits",
    "KEMAR_ORIGIN", "OBJECTS", "SOUND_SOURCES", "ARM_LIMITS", "HEAD_LIMITS", "KEMAR_LIMIT", "ROOM", "TORSO_RANGE",
    "ARM_JOINTS", "Header", "HeadCommand", "Image", "JointState", "LaserScan", "LeftArmCommand", "Odometry", "Point",
    "Pose", "PoseStamped", "PositionCommand", "Quaternion", "RightArmCommand", "Timestamp", "TorsoCommand", "Twist",
    "Vector3",
]
