"""The ROS 2 message types a recording writes: the standard ones, and ``aiogenomix_msgs/msg/AudioFrames``.

The standard types are spelled as their packages define them (``std_msgs``,
``sensor_msgs``, ``nav_msgs``, ``geometry_msgs``, ``audio_common_msgs`` of
audio_common 0.4), so every ROS 2 tool reads them without our help.  One type is
ours: a standard audio message has no frame index, so each ``AudioDataStamped``
message has a twin ``AudioFrames`` message (same sequence number, same stamp) on the
channel beside it, saying which frames it holds, what was lost before it, and where
the head was.
"""

from __future__ import annotations

from ._cdr import Field, MessageType

__all__ = [
    "TIME", "HEADER", "JOINT_STATE", "IMAGE", "LASER_SCAN", "ODOMETRY", "POSE_STAMPED", "AUDIO_DATA",
    "AUDIO_DATA_STAMPED", "AUDIO_INFO", "AUDIO_FRAMES", "POINT", "QUATERNION", "POSE", "VECTOR3", "TWIST",
]

TIME = MessageType("builtin_interfaces/msg/Time", (Field("sec", "int32"), Field("nanosec", "uint32")))
HEADER = MessageType("std_msgs/msg/Header", (Field("stamp", TIME), Field("frame_id", "string")))

POINT = MessageType("geometry_msgs/msg/Point", (Field("x", "float64"), Field("y", "float64"), Field("z", "float64")))
QUATERNION = MessageType("geometry_msgs/msg/Quaternion", (
    Field("x", "float64"), Field("y", "float64"), Field("z", "float64"), Field("w", "float64")))
POSE = MessageType("geometry_msgs/msg/Pose", (Field("position", POINT), Field("orientation", QUATERNION)))
POSE_STAMPED = MessageType("geometry_msgs/msg/PoseStamped", (Field("header", HEADER), Field("pose", POSE)))
VECTOR3 = MessageType("geometry_msgs/msg/Vector3", (Field("x", "float64"), Field("y", "float64"),
                                                    Field("z", "float64")))
TWIST = MessageType("geometry_msgs/msg/Twist", (Field("linear", VECTOR3), Field("angular", VECTOR3)))
POSE_WITH_COVARIANCE = MessageType("geometry_msgs/msg/PoseWithCovariance", (
    Field("pose", POSE), Field("covariance", "float64", 36)))
TWIST_WITH_COVARIANCE = MessageType("geometry_msgs/msg/TwistWithCovariance", (
    Field("twist", TWIST), Field("covariance", "float64", 36)))
ODOMETRY = MessageType("nav_msgs/msg/Odometry", (
    Field("header", HEADER), Field("child_frame_id", "string"), Field("pose", POSE_WITH_COVARIANCE),
    Field("twist", TWIST_WITH_COVARIANCE)))

JOINT_STATE = MessageType("sensor_msgs/msg/JointState", (
    Field("header", HEADER), Field("name", "string", -1), Field("position", "float64", -1),
    Field("velocity", "float64", -1), Field("effort", "float64", -1)))
IMAGE = MessageType("sensor_msgs/msg/Image", (
    Field("header", HEADER), Field("height", "uint32"), Field("width", "uint32"), Field("encoding", "string"),
    Field("is_bigendian", "uint8"), Field("step", "uint32"), Field("data", "uint8", -1)))
LASER_SCAN = MessageType("sensor_msgs/msg/LaserScan", (
    Field("header", HEADER), Field("angle_min", "float32"), Field("angle_max", "float32"),
    Field("angle_increment", "float32"), Field("time_increment", "float32"), Field("scan_time", "float32"),
    Field("range_min", "float32"), Field("range_max", "float32"), Field("ranges", "float32", -1),
    Field("intensities", "float32", -1)))

AUDIO_DATA = MessageType("audio_common_msgs/msg/AudioData", (Field("data", "uint8", -1),))
AUDIO_DATA_STAMPED = MessageType("audio_common_msgs/msg/AudioDataStamped", (
    Field("header", HEADER), Field("audio", AUDIO_DATA)))
AUDIO_INFO = MessageType("audio_common_msgs/msg/AudioInfo", (
    Field("channels", "uint8"), Field("sample_rate", "uint32"), Field("sample_format", "string"),
    Field("bitrate", "uint32"), Field("coding_format", "string")))

AUDIO_FRAMES = MessageType("aiogenomix_msgs/msg/AudioFrames", (
    Field("header", HEADER, comment="stamp: the capture's own time of the first frame (the rig's clock)"),
    Field("first_frame", "uint64", comment="number of the first frame; frames count from 1 at the capture's start"),
    Field("frames", "uint32", comment="frames in the audio message of the same sequence number"),
    Field("chunk", "uint64", comment="the capture's number of this chunk (capture: Port index; bass: "
                                     "lastFrameIndex / nFramesPerChunk)"),
    Field("lost_frames", "uint64", comment="frames the recording missed just before this one (0: contiguous)"),
    Field("head_azimuth", "float64", comment="head azimuth at the end of the chunk, degrees, positive to the "
                                             "left; NaN when the port carries none"),
    Field("sample_rate", "uint32", comment="frames per second"),
), comment=("Where the audio_common_msgs/AudioDataStamped message of the same sequence number sits in the\n"
            "capture (aiogenomix recordings, docs/decisions/0031)."))
