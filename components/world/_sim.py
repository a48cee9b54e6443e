"""The simulated room: MuJoCo model and data, stepped on the runtime clock, with the robots' servos.

Everything here runs on the event loop's thread and is quick (a step of this model takes tens of
microseconds); rendering works on a copy of the joint positions in :mod:`._render`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ._mjcf import HEAD_LIMITS, KEMAR_LIMIT, TORSO_RANGE, arm_limits, scene_xml
from ._mujoco import import_mujoco
from ._servo import JointServo, base_velocity, wrap_angle
from ._types import ARM_JOINTS

__all__ = ["Simulation", "PR2_JOINTS", "BASE_LIMITS"]

#: The PR2's joints reported on ``pr2_joints``, in order.
PR2_JOINTS = ("torso_lift_joint", "head_pan_joint", "head_tilt_joint",
              *(f"l_{j}" for j in ARM_JOINTS), *(f"r_{j}" for j in ARM_JOINTS))
#: Top speeds of the base: linear (m/s) and angular (rad/s), the PR2's.
BASE_LIMITS = (1.0, 1.0)
#: Top speed of the KEMAR's neck in the simulation (rad/s), as our kemar's drive allows.
KEMAR_MAX_SPEED = math.radians(900.0)
#: Torso speed limit of the simulation (m/s): faster than the real PR2's 0.013 m/s, so that motions
#: over the whole range can be asked in a second, as the seed's scripts did.
TORSO_MAX_SPEED = 0.5
#: At most this many physics steps per call of :meth:`Simulation.advance` (the event loop's share):
#: a simulation behind the clock catches up over the next calls.
MAX_STEPS = 200
#: Behind the clock by more than this (s), the simulation drops the time rather than chase it
#: (MORSE's "best effort"): motions under way then end early on the clock.
MAX_LAG = 5.0


def _servos() -> dict[str, JointServo]:
    servos = {"torso_lift_joint": JointServo(*TORSO_RANGE, TORSO_MAX_SPEED)}
    servos.update({name: JointServo(*limits) for name, limits in HEAD_LIMITS.items()})
    for side in "lr":
        servos.update({name: JointServo(*limits) for name, limits in arm_limits(side).items()})
    return servos


class Simulation:
    """The scene and its robots.

    Args:
        width: Camera width in pixels (sizes the offscreen buffer).
        height: Camera height in pixels.
    """

    def __init__(self, width: int = 256, height: int = 256) -> None:
        self.mujoco = import_mujoco()
        self.model: Any = self.mujoco.MjModel.from_xml_string(scene_xml(width, height))
        self.data: Any = self.mujoco.MjData(self.model)
        self._qpos = {self.model.joint(i).name: int(self.model.joint(i).qposadr[0]) for i in range(self.model.njnt)}
        self._dof = {self.model.joint(i).name: int(self.model.joint(i).dofadr[0]) for i in range(self.model.njnt)}
        self._actuator = {self.model.actuator(i).name: i for i in range(self.model.nu)}
        self.servos = _servos()
        for name, servo in self.servos.items():
            servo.move(self.position(name), self.position(name), 0.0, 0.0)
        self._base_goal: tuple[float, float, float] | None = None
        self._base_twist = (0.0, 0.0, 0.0)  # in the robot's frame: forward, left, turn
        self.kemar_speed = 0.0
        self.mujoco.mj_forward(self.model, self.data)

    @property
    def time(self) -> float:
        """Simulated seconds since the start."""
        return float(self.data.time)

    # -- state -----------------------------------------------------------------------------

    def position(self, joint: str) -> float:
        """The position of *joint* (rad or m)."""
        return float(self.data.qpos[self._qpos[joint]])

    def speed(self, joint: str) -> float:
        """The speed of *joint* (rad/s or m/s)."""
        return float(self.data.qvel[self._dof[joint]])

    def base_pose(self) -> tuple[float, float, float]:
        """The PR2 base: x, y (m), heading (rad, in (-π, π])."""
        return self.position("base_x"), self.position("base_y"), wrap_angle(self.position("base_yaw"))

    def base_speed(self) -> tuple[float, float, float]:
        """The PR2 base's speeds in the room's frame: vx, vy (m/s), vw (rad/s)."""
        return self.speed("base_x"), self.speed("base_y"), self.speed("base_yaw")

    def kemar_yaw(self) -> float:
        """The KEMAR's head azimuth (rad, positive = left)."""
        return self.position("kemar_head_yaw")

    def joint_positions(self, joints: tuple[str, ...]) -> np.ndarray:
        """The positions of *joints*, in order."""
        return np.array([self.position(j) for j in joints])

    def joint_speeds(self, joints: tuple[str, ...]) -> np.ndarray:
        """The speeds of *joints*, in order."""
        return np.array([self.speed(j) for j in joints])

    def snapshot(self) -> np.ndarray:
        """A copy of every joint position, all a renderer needs to draw the scene as it is now."""
        return np.array(self.data.qpos, copy=True)

    # -- commands --------------------------------------------------------------------------

    def move_joints(self, goals: dict[str, float], duration: float) -> None:
        """Start moving *goals*' joints from where they are, to arrive in *duration* s (or as fast as they can)."""
        for joint, goal in goals.items():
            self.servos[joint].move(self.position(joint), goal, self.time, duration)

    def drive_to(self, x: float, y: float, w: float) -> None:
        """Drive the base to a pose of the room (replaces any velocity command)."""
        self._base_goal = (x, y, w)

    def drive(self, forward: float, left: float, turn: float) -> None:
        """Drive the base at a speed in its own frame (replaces any pose goal)."""
        self._base_goal = None
        self._base_twist = (forward, left, turn)

    # -- physics ---------------------------------------------------------------------------

    def advance(self, until: float) -> int:
        """Step the physics towards simulated time *until* (at most :data:`MAX_STEPS` steps); return the steps."""
        timestep = float(self.model.opt.timestep)
        steps = min(MAX_STEPS, max(0, math.floor((until - self.time) / timestep + 1e-9)))
        for _ in range(steps):
            self._control()
            self.mujoco.mj_step(self.model, self.data)
            self._stop_at_switches()
        if until - self.time > MAX_LAG:
            self.data.time = until
        return steps

    def _stop_at_switches(self) -> None:
        """The neck's limit switches are hard: a step that carried the head past one ends on it, at rest.

        (MuJoCo's joint limits are soft constraints, and the head's momentum can take it a
        fraction of a degree past them when its speed command comes late.)
        """
        address, dof = self._qpos["kemar_head_yaw"], self._dof["kemar_head_yaw"]
        yaw = float(self.data.qpos[address])
        if abs(yaw) > KEMAR_LIMIT:
            self.data.qpos[address] = math.copysign(KEMAR_LIMIT, yaw)
            self.data.qvel[dof] = 0.0

    def _control(self) -> None:
        ctrl = self.data.ctrl
        now = self.time
        for joint, servo in self.servos.items():
            ctrl[self._actuator[joint]] = servo.speed(self.position(joint), now)
        if self._base_goal is not None:
            vx, vy, vw = base_velocity(self.base_pose(), self._base_goal, max_linear=0.5, max_angular=BASE_LIMITS[1])
        else:
            forward, left, turn = self._base_twist
            heading = self.position("base_yaw")
            vx = math.cos(heading) * forward - math.sin(heading) * left
            vy = math.sin(heading) * forward + math.cos(heading) * left
            vw = turn
        linear = math.hypot(vx, vy)
        if linear > BASE_LIMITS[0]:
            vx, vy = vx * BASE_LIMITS[0] / linear, vy * BASE_LIMITS[0] / linear
        ctrl[self._actuator["base_x"]] = vx
        ctrl[self._actuator["base_y"]] = vy
        ctrl[self._actuator["base_yaw"]] = max(-BASE_LIMITS[1], min(BASE_LIMITS[1], vw))
        # The limit switches: the neck stops at its limit, never past it within a step.
        yaw, step = self.kemar_yaw(), float(self.model.opt.timestep)
        room_left, room_right = max(0.0, KEMAR_LIMIT - yaw) / step, max(0.0, KEMAR_LIMIT + yaw) / step
        speed = max(-min(KEMAR_MAX_SPEED, room_right), min(KEMAR_MAX_SPEED, room_left, self.kemar_speed))
        ctrl[self._actuator["kemar_head_yaw"]] = speed
