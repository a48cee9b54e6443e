"""Joint servos of the simulated robots: minimum-jerk trajectories tracked in velocity (sans-I/O)."""

from __future__ import annotations

import dataclasses
import math

__all__ = ["Trajectory", "JointServo", "base_velocity", "wrap_angle"]

#: Position gain of the servos (1/s): what is left of the error after the feed-forward is corrected at this rate.
GAIN = 20.0


def wrap_angle(angle: float) -> float:
    """*angle* brought into (-π, π]."""
    return math.remainder(angle, 2 * math.pi) + 0.0


@dataclasses.dataclass(frozen=True)
class Trajectory:
    """A minimum-jerk motion from *start* to *goal* beginning at *t0*, lasting *duration* seconds."""

    start: float
    goal: float
    t0: float
    duration: float

    def at(self, t: float) -> tuple[float, float]:
        """The reference position and speed at time *t*."""
        if self.duration <= 0 or t >= self.t0 + self.duration:
            return self.goal, 0.0
        tau = max(0.0, (t - self.t0) / self.duration)
        shape = tau ** 3 * (10 - 15 * tau + 6 * tau * tau)
        slope = 30 * tau * tau * (1 - tau) ** 2 / self.duration
        span = self.goal - self.start
        return self.start + span * shape, span * slope


@dataclasses.dataclass
class JointServo:
    """One joint: its limits, its top speed, and the trajectory it follows (holding the last goal after it)."""

    lower: float | None
    upper: float | None
    max_speed: float
    trajectory: Trajectory | None = None

    def clamp(self, position: float) -> float:
        """*position* brought within the joint's range."""
        if self.lower is not None and position < self.lower:
            return self.lower
        if self.upper is not None and position > self.upper:
            return self.upper
        return position

    def move(self, position: float, goal: float, now: float, duration: float) -> None:
        """Go from *position* to *goal* (clamped to the range) in *duration* s, or slower if too fast for the joint."""
        goal = self.clamp(goal)
        # The peak speed of a minimum-jerk motion is 1.875 × its mean speed.
        shortest = 1.875 * abs(goal - position) / self.max_speed
        self.trajectory = Trajectory(position, goal, now, max(duration, shortest))

    def speed(self, position: float, now: float) -> float:
        """The speed to command now: the trajectory's, plus a correction of the position error."""
        if self.trajectory is None:
            return 0.0
        reference, feed_forward = self.trajectory.at(now)
        command = feed_forward + GAIN * (reference - position)
        return max(-self.max_speed, min(self.max_speed, command))


def base_velocity(pose: tuple[float, float, float], goal: tuple[float, float, float], *,
                  gain: float = 2.0, max_linear: float = 0.5, max_angular: float = 1.0) -> tuple[float, float, float]:
    """The room-frame speed (vx, vy, vw) that drives a holonomic base at *pose* to *goal* (x, y, w).

    A proportional controller, saturated: the base goes straight at up to *max_linear* m/s while
    turning at up to *max_angular* rad/s, and slows exponentially near the goal.
    """
    dx, dy, dw = goal[0] - pose[0], goal[1] - pose[1], wrap_angle(goal[2] - pose[2])
    vx, vy = gain * dx, gain * dy
    norm = math.hypot(vx, vy)
    if norm > max_linear:
        vx, vy = vx * max_linear / norm, vy * max_linear / norm
    vw = max(-max_angular, min(max_angular, gain * dw))
    return vx, vy, vw
