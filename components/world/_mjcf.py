"""The MJCF scene of the virtual robots: the room, its coloured objects and sound-source markers, a PR2, a KEMAR.

Written here rather than shipped as XML files so the arm chains are generated from one table of
joints.  Joint names, limits and speeds of the PR2 follow its URDF (``pr2_description``); the KEMAR's
head turns within the limits of our motorised neck (``kemar``: ±90°).  Gravity is off: nothing in
the room falls, and every robot joint is servoed in velocity by ``world``.
"""

from __future__ import annotations

import math

from ._types import ARM_JOINTS

__all__ = ["scene_xml", "arm_limits", "ARM_LIMITS", "HEAD_LIMITS", "TORSO_RANGE", "KEMAR_LIMIT", "PR2_CAMERAS",
           "KEMAR_CAMERAS", "KEMAR_ORIGIN", "SOUND_SOURCES", "ROOM", "OBJECTS", "PR2_GEOM_GROUP", "CAMERA_HEIGHT",
           "WALL_HEIGHT", "KEMAR_EAR_HEIGHT"]

#: Torso lift range (m).
TORSO_RANGE = (0.0, 0.31)
#: (lower, upper, max speed) of the head joints, rad and rad/s; positive tilt looks down, as on the PR2.
HEAD_LIMITS = {"head_pan_joint": (-2.857, 2.857, 6.0), "head_tilt_joint": (-0.3712, 1.29626, 5.0)}
#: (lower, upper, max speed) of the left arm's joints; None bounds are continuous joints.
ARM_LIMITS: dict[str, tuple[float | None, float | None, float]] = {
    "shoulder_pan_joint": (-0.7146, 2.2854, 2.088),
    "shoulder_lift_joint": (-0.5236, 1.3963, 2.082),
    "upper_arm_roll_joint": (-0.8, 3.9, 3.27),
    "elbow_flex_joint": (-2.3213, 0.0, 3.3),
    "forearm_roll_joint": (None, None, 3.6),
    "wrist_flex_joint": (-2.18, 0.0, 3.078),
    "wrist_roll_joint": (None, None, 3.6),
}
#: Joints whose range the right arm mirrors (lower, upper) -> (-upper, -lower).
_MIRRORED = ("shoulder_pan_joint", "upper_arm_roll_joint")


def arm_limits(side: str) -> dict[str, tuple[float | None, float | None, float]]:
    """(lower, upper, max speed) of the joints of arm *side* (``"l"`` or ``"r"``), by their full names.

    The right arm mirrors the left's shoulder pan and upper-arm roll, as on the PR2.
    """
    limits = {}
    for joint, (lower, upper, speed) in ARM_LIMITS.items():
        if side == "r" and joint in _MIRRORED:
            assert lower is not None and upper is not None  # the mirrored joints have limits
            lower, upper = -upper, -lower
        limits[f"{side}_{joint}"] = (lower, upper, speed)
    return limits

#: The KEMAR's head yaw limit, rad (our kemar's limit switches are at ±90°).
KEMAR_LIMIT = math.radians(90.0)
#: Where the KEMAR stands (x, y, m), facing +x.
KEMAR_ORIGIN = (-2.0, 1.5)
#: The PR2's head cameras; the first is ``pr2_video``.
PR2_CAMERAS = ("wide_stereo_l", "wide_stereo_r")
#: The KEMAR's eye cameras (left, right).
KEMAR_CAMERAS = ("kemar_eye_left", "kemar_eye_right")
#: Height of the PR2 head cameras with the torso down and the head level (m).
CAMERA_HEIGHT = 1.22
#: Geom group of the PR2's parts (the base laser does not see the robot it is on).
PR2_GEOM_GROUP = 2
#: Sound-source markers: name -> (x, y, z) in m.
SOUND_SOURCES = {"source_1": (2.0, 2.5, 1.5), "source_2": (-1.0, -2.5, 1.5)}
#: Distinctly coloured objects: name -> (geom type, position, size, rgba).
OBJECTS = {
    # Straight ahead of the PR2's head cameras at start.
    "red_box": ("box", (3.0, 0.0, CAMERA_HEIGHT), (0.2, 0.2, 0.2), (0.9, 0.05, 0.05, 1)),
    # Straight ahead of the KEMAR's eyes at start, and 45° to its left.
    "green_cylinder": ("cylinder", (KEMAR_ORIGIN[0] + 2.5, KEMAR_ORIGIN[1], 1.5), (0.12, 0.15, 0),
                       (0.05, 0.8, 0.05, 1)),
    "blue_sphere": ("sphere", (KEMAR_ORIGIN[0] + 2.5 * math.cos(math.pi / 4),
                               KEMAR_ORIGIN[1] + 2.5 * math.sin(math.pi / 4), 1.5), (0.13, 0, 0), (0.05, 0.1, 0.9, 1)),
}

#: The floor inside the walls: x min, x max, y min, y max (m).
ROOM = (-4.0, 6.0, -4.0, 4.0)
#: How high the walls are (m): the room is the box of ROOM's floor up to here.
WALL_HEIGHT = 3.0
#: Height of the centre of the KEMAR's head above the floor (m), between its ears.
KEMAR_EAR_HEIGHT = 1.47


def _vec(values: tuple[float, ...]) -> str:
    return " ".join(f"{v:.6g}" for v in values)


def _room() -> str:
    x0, x1, y0, y1 = ROOM
    cx, cy, hx, hy, height = (x0 + x1) / 2, (y0 + y1) / 2, (x1 - x0) / 2, (y1 - y0) / 2, WALL_HEIGHT / 2
    walls = [
        ("wall_north", (cx, y1 + 0.05, height), (hx, 0.05, height)),
        ("wall_south", (cx, y0 - 0.05, height), (hx, 0.05, height)),
        ("wall_east", (x1 + 0.05, cy, height), (0.05, hy, height)),
        ("wall_west", (x0 - 0.05, cy, height), (0.05, hy, height)),
    ]
    parts = [f'<geom name="floor" type="plane" size="{hx + 1} {hy + 1} 0.1" pos="{cx} {cy} 0" material="floor"/>']
    parts += [f'<geom name="{name}" type="box" pos="{_vec(pos)}" size="{_vec(size)}" material="wall"/>'
              for name, pos, size in walls]
    for name, (kind, pos, size, rgba) in OBJECTS.items():
        parts.append(f'<geom name="{name}" type="{kind}" pos="{_vec(pos)}" size="{_vec(size)}" rgba="{_vec(rgba)}"/>')
        # A grey stand under each object, so nothing floats.
        half = (pos[2] - 0.15) / 2
        parts.append(f'<geom name="{name}_stand" type="cylinder" pos="{pos[0]:.6g} {pos[1]:.6g} {half:.6g}"'
                     f' size="0.03 {half:.6g}" rgba="0.4 0.4 0.4 1"/>')
    for name, pos in SOUND_SOURCES.items():
        parts.append(f'<geom name="{name}" type="sphere" pos="{_vec(pos)}" size="0.08" rgba="1 0.85 0.1 1"'
                     ' contype="0" conaffinity="0"/>')
    parts.append('<light name="ceiling_1" pos="0 0 4" dir="0 0 -1" diffuse="0.6 0.6 0.6" directional="false"/>')
    parts.append('<light name="ceiling_2" pos="3 0 4" dir="0 0 -1" diffuse="0.4 0.4 0.4"/>')
    return "\n    ".join(parts)


def _joint(name: str, axis: str, limits: tuple[float | None, float | None, float]) -> str:
    lower, upper, _ = limits
    bounds = f' range="{lower} {upper}" limited="true"' if lower is not None else ' limited="false"'
    return f'<joint name="{name}" type="hinge" axis="{axis}"{bounds}/>'


def _arm(side: str) -> str:
    sign = 1.0 if side == "l" else -1.0
    axes = ["0 0 1", "0 1 0", "1 0 0", "0 1 0", "1 0 0", "0 1 0", "1 0 0"]
    offsets = ["0 0 0", "0.1 0 0", "0 0 0", "0.4 0 0", "0 0 0", "0.321 0 0", "0 0 0"]
    geoms = [
        '<geom type="sphere" size="0.09" material="pr2_dark"/>',
        '<geom type="sphere" size="0.07" material="pr2_light"/>',
        '<geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.055" material="pr2_light"/>',
        '<geom type="sphere" size="0.06" material="pr2_dark"/>',
        '<geom type="capsule" fromto="0 0 0 0.321 0 0" size="0.045" material="pr2_light"/>',
        '<geom type="sphere" size="0.04" material="pr2_dark"/>',
        '<geom type="box" pos="0.08 0 0" size="0.06 0.03 0.02" material="pr2_dark"/>',
    ]
    opening = []
    limits = arm_limits(side)
    for joint, axis, offset, geom in zip(ARM_JOINTS, axes, offsets, geoms, strict=True):
        link = joint.replace("_joint", "_link")
        opening.append(f'<body name="{side}_{link}" pos="{offset}">'
                       f'{_joint(f"{side}_{joint}", axis, limits[f"{side}_{joint}"])}{geom}')
    return (f'<body name="{side}_shoulder" pos="0 {sign * 0.188} 0">'
            + "".join(opening) + "</body>" * len(opening) + "</body>")


def _pr2() -> str:
    pan, tilt, lift = HEAD_LIMITS["head_pan_joint"], HEAD_LIMITS["head_tilt_joint"], TORSO_RANGE
    cameras = "".join(
        f'<camera name="{name}" pos="0.1 {y} 0.1" xyaxes="0 -1 0 0 0 1" fovy="90"/>'
        for name, y in zip(PR2_CAMERAS, (0.045, -0.045), strict=True))
    return f"""<body name="base_footprint" childclass="pr2">
      <joint name="base_x" type="slide" axis="1 0 0"/>
      <joint name="base_y" type="slide" axis="0 1 0"/>
      <joint name="base_yaw" type="hinge" axis="0 0 1"/>
      <geom name="base" type="box" pos="0 0 0.16" size="0.33 0.33 0.13" material="pr2_dark"/>
      <site name="base_laser" pos="0.275 0 0.3" size="0.02"/>
      <body name="torso_lift_link" pos="-0.05 0 0.74">
        <joint name="torso_lift_joint" type="slide" axis="0 0 1" range="{lift[0]} {lift[1]}" limited="true"/>
        <geom type="box" pos="0 0 -0.2" size="0.1 0.22 0.3" material="pr2_light"/>
        <body name="head_pan_link" pos="-0.017 0 0.38">
          {_joint("head_pan_joint", "0 0 1", pan)}
          <geom type="cylinder" pos="0 0 -0.04" size="0.05 0.04" material="pr2_dark"/>
          <body name="head_tilt_link" pos="0.068 0 0">
            {_joint("head_tilt_joint", "0 1 0", tilt)}
            <geom type="box" pos="0 0 0.08" size="0.07 0.15 0.05" material="pr2_light"/>
            {cameras}
          </body>
        </body>
        {_arm("l")}
        {_arm("r")}
      </body>
    </body>"""


def _kemar() -> str:
    x, y = KEMAR_ORIGIN
    limit = KEMAR_LIMIT
    return f"""<body name="kemar" pos="{x} {y} 0">
      <geom type="cylinder" pos="0 0 0.5" size="0.03 0.5" rgba="0.3 0.3 0.3 1"/>
      <geom type="box" pos="0 0 1.15" size="0.12 0.2 0.17" material="kemar_skin"/>
      <geom type="cylinder" pos="0 0 1.34" size="0.045 0.04" material="kemar_skin"/>
      <body name="kemar_head" pos="0 0 {KEMAR_EAR_HEIGHT}">
        <joint name="kemar_head_yaw" type="hinge" axis="0 0 1" range="{-limit} {limit}" limited="true"/>
        <geom type="ellipsoid" size="0.095 0.08 0.115" material="kemar_skin"/>
        <geom type="ellipsoid" pos="0 0.085 0" size="0.02 0.012 0.03" material="kemar_skin"/>
        <geom type="ellipsoid" pos="0 -0.085 0" size="0.02 0.012 0.03" material="kemar_skin"/>
        <camera name="{KEMAR_CAMERAS[0]}" pos="0.1 0.033 0.03" xyaxes="0 -1 0 0 0 1" fovy="60"/>
        <camera name="{KEMAR_CAMERAS[1]}" pos="0.1 -0.033 0.03" xyaxes="0 -1 0 0 0 1" fovy="60"/>
      </body>
    </body>"""


def _actuators() -> str:
    # Velocity servos: world computes each joint's speed (trajectory feed-forward plus a position
    # correction) and MuJoCo integrates it; kv is high and integrated implicitly (implicitfast).
    rows = [("base_x", 20000), ("base_y", 20000), ("base_yaw", 5000), ("torso_lift_joint", 10000),
            ("head_pan_joint", 50), ("head_tilt_joint", 50), ("kemar_head_yaw", 50)]
    rows += [(f"{side}_{joint}", 300) for side in "lr" for joint in ARM_JOINTS]
    return "\n    ".join(f'<velocity name="{joint}" joint="{joint}" kv="{kv}"/>' for joint, kv in rows)


def scene_xml(width: int = 256, height: int = 256) -> str:
    """The MJCF text of the whole scene, with offscreen buffers for cameras of *width* × *height*."""
    return f"""<mujoco model="two_ears_hall">
  <compiler angle="radian"/>
  <option timestep="0.005" gravity="0 0 0" integrator="implicitfast"/>
  <visual>
    <global offwidth="{max(width, 640)}" offheight="{max(height, 480)}"/>
    <quality shadowsize="0"/>
    <headlight ambient="0.35 0.35 0.35" diffuse="0.4 0.4 0.4"/>
  </visual>
  <asset>
    <texture name="floor" type="2d" builtin="checker" rgb1="0.55 0.55 0.55" rgb2="0.45 0.45 0.45"
             width="64" height="64"/>
    <material name="floor" texture="floor" texrepeat="10 10"/>
    <material name="wall" rgba="0.78 0.76 0.7 1"/>
    <material name="pr2_dark" rgba="0.2 0.2 0.22 1"/>
    <material name="pr2_light" rgba="0.85 0.85 0.85 1"/>
    <material name="kemar_skin" rgba="0.72 0.66 0.6 1"/>
  </asset>
  <default>
    <default class="pr2">
      <geom group="{PR2_GEOM_GROUP}" contype="0" conaffinity="0" density="300"/>
    </default>
    <geom contype="0" conaffinity="0"/>
    <joint armature="0.05"/>
  </default>
  <worldbody>
    {_room()}
    {_pr2()}
    {_kemar()}
  </worldbody>
  <actuator>
    {_actuators()}
  </actuator>
</mujoco>"""
