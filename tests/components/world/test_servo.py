"""The servos of the simulated robots, without a simulation: trajectories, limits, the base controller."""

from __future__ import annotations

import math

import pytest

from aiogenomix.components.world._servo import JointServo, Trajectory, base_velocity, wrap_angle


def test_a_minimum_jerk_trajectory_starts_and_ends_at_rest() -> None:
    motion = Trajectory(start=0.0, goal=0.2, t0=1.0, duration=1.0)
    assert motion.at(0.5) == (0.0, 0.0)
    assert motion.at(1.5) == pytest.approx((0.1, 1.875 * 0.2))  # halfway, at its peak speed
    assert motion.at(2.0) == (0.2, 0.0)
    assert motion.at(9.0) == (0.2, 0.0)


def test_a_servo_keeps_its_goal_in_range_and_never_outruns_its_joint() -> None:
    servo = JointServo(lower=0.0, upper=0.31, max_speed=0.5)
    servo.move(position=0.0, goal=0.5, now=0.0, duration=0.1)
    assert servo.trajectory is not None
    assert servo.trajectory.goal == 0.31
    assert servo.trajectory.duration == pytest.approx(1.875 * 0.31 / 0.5)  # slower than asked, as fast as it can
    assert abs(servo.speed(0.0, servo.trajectory.duration / 2)) <= 0.5


def test_the_base_goes_straight_at_its_top_speed_then_slows_near_the_goal() -> None:
    vx, vy, vw = base_velocity((0.0, 0.0, 0.0), (3.0, 4.0, 0.0), max_linear=0.5)
    assert (vx, vy, vw) == pytest.approx((0.3, 0.4, 0.0))
    vx, vy, vw = base_velocity((0.0, 0.0, 3.0), (0.01, 0.0, -3.0), gain=2.0)
    assert vx == pytest.approx(0.02) and vy == 0.0
    assert vw > 0  # the short way round, across ±π


def test_angles_wrap_into_minus_pi_to_pi() -> None:
    assert wrap_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2)
    assert wrap_angle(0.0) == 0.0
