"""The ROS 2 message types of recordings: our CDR read back by the robotics toolbox's two decoders, and by ours."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from mcap_ros2._dynamic import generate_dynamic
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from aiogenomix.components.recording import (
    AUDIO_DATA_STAMPED, AUDIO_FRAMES, AUDIO_INFO, IMAGE, JOINT_STATE, LASER_SCAN, ODOMETRY, POSE_STAMPED, CdrError,
    MessageType,
)

HEADER = {"stamp": {"sec": 1795700000, "nanosec": 123456789}, "frame_id": "kemar"}
SAMPLES = np.array([[1, -1], [2**31 - 1, -2**31], [7, 0]], dtype="<i4")

CASES: list[tuple[MessageType, dict[str, Any]]] = [
    (AUDIO_DATA_STAMPED, {"header": HEADER, "audio": {"data": SAMPLES.tobytes()}}),
    (AUDIO_FRAMES, {"header": HEADER, "first_frame": 2**40 + 1, "frames": 2205, "chunk": 3, "lost_frames": 4410,
                    "head_azimuth": -12.5, "sample_rate": 44100}),
    (AUDIO_INFO, {"channels": 2, "sample_rate": 44100, "sample_format": "S32LE", "bitrate": 2822400,
                  "coding_format": "wave"}),
    (JOINT_STATE, {"header": HEADER, "name": ["head_yaw", "neck"], "position": [0.5, -0.25], "velocity": [1.0, 0.0],
                   "effort": []}),
    (IMAGE, {"header": HEADER, "height": 2, "width": 3, "encoding": "rgba8", "is_bigendian": 0, "step": 12,
             "data": bytes(range(24))}),
    (LASER_SCAN, {"header": HEADER, "angle_min": -2.0, "angle_max": 2.0, "angle_increment": 0.5,
                  "time_increment": 0.0, "scan_time": 0.1, "range_min": 0.02, "range_max": 30.0,
                  "ranges": np.array([1.5, 30.0, math.inf], np.float32), "intensities": []}),
    (ODOMETRY, {"header": HEADER, "child_frame_id": "base_footprint",
                "pose": {"pose": {"position": {"x": 1.0, "y": 2.0, "z": 0.0},
                                  "orientation": {"x": 0.0, "y": 0.0, "z": 0.5, "w": 0.75}},
                         "covariance": np.arange(36.0)},
                "twist": {"twist": {"linear": {"x": 0.1, "y": 0.0, "z": 0.0},
                                    "angular": {"x": 0.0, "y": 0.0, "z": 0.2}}, "covariance": np.zeros(36)}}),
    (POSE_STAMPED, {"header": HEADER, "pose": {"position": {"x": 0.5, "y": 0.25, "z": 1.47},
                                               "orientation": {"x": 0.0, "y": 0.0, "z": 0.1, "w": 0.99}}}),
]


def plain(value: Any) -> Any:
    """A decoded message of any of the three decoders as plain Python data, to compare them."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items() if not k.startswith("__")}
    if hasattr(value, "__slots__") or hasattr(value, "__dict__") and not isinstance(value, (bytes, str)):
        fields = getattr(value, "__slots__", None) or vars(value)
        return {k: plain(getattr(value, k)) for k in fields if not k.startswith("__")}
    if isinstance(value, (bytes, bytearray, np.ndarray, list, tuple)) and not isinstance(value, str):
        return [plain(v) for v in (list(value) if not isinstance(value, (bytes, bytearray)) else list(value))]
    if isinstance(value, np.generic):
        return value.item()
    return value


@pytest.mark.parametrize(("kind", "value"), CASES, ids=[kind.name for kind, _ in CASES])
def test_a_message_reads_the_same_in_every_decoder(kind: MessageType, value: dict[str, Any]) -> None:
    data = kind.encode(value)
    ours = plain(kind.decode(data))
    mcap_ros2 = plain(generate_dynamic(kind.name, kind.definition())[kind.name](data))
    store = get_typestore(Stores.EMPTY)
    store.register(get_types_from_msg(kind.definition(), kind.name))
    rosbags = plain(store.deserialize_cdr(data, kind.name))
    assert ours == mcap_ros2 == rosbags
    # And they hold what was written.
    assert plain(kind.decode(kind.encode(kind.decode(data)))) == ours


def test_audio_samples_come_back_bit_for_bit() -> None:
    decoded = AUDIO_DATA_STAMPED.decode(AUDIO_DATA_STAMPED.encode({"header": HEADER,
                                                                   "audio": {"data": SAMPLES.tobytes()}}))
    np.testing.assert_array_equal(decoded["audio"]["data"].view("<i4").reshape(-1, 2), SAMPLES)


def test_our_frame_index_type_is_defined_in_the_recording() -> None:
    text = AUDIO_FRAMES.definition()
    assert text.startswith("# Where the audio_common_msgs/AudioDataStamped message of the same sequence number")
    assert "uint64 first_frame  # number of the first frame" in text
    assert "\nMSG: std_msgs/Header\n" in text and "\nMSG: builtin_interfaces/Time\n" in text


def test_a_truncated_message_or_a_fixed_array_of_the_wrong_size_is_refused() -> None:
    data = AUDIO_FRAMES.encode({"frames": 1})
    with pytest.raises(CdrError, match="truncated"):
        AUDIO_FRAMES.decode(data[:-3])
    with pytest.raises(CdrError, match="not a little-endian CDR message"):
        AUDIO_FRAMES.decode(b"\x00\x00" + data[2:])
    with pytest.raises(CdrError, match="covariance is an array of 36, not 3"):
        ODOMETRY.encode({"pose": {"covariance": [1, 2, 3]}})
