"""Trapezoidal motion profiles as piecewise-constant acceleration, evaluated analytically in time."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

__all__ = ["Trajectory", "plan_move", "plan_jog", "plan_stop", "move_duration"]

# Below this, a duration or a distance is treated as zero (seconds, counts).
_EPS = 1e-12
# Below this, a velocity is zero: float residues of v0 + a*t must not leave a
# stopped axis creeping (counts/s).
_VEL_EPS = 1e-6


@dataclass(frozen=True)
class Trajectory:
    """A one-axis motion starting at time *t0*.

    The motion is a list of ``(duration, acceleration)`` segments, followed by
    constant velocity forever (zero for a move that ends at rest).  Positions are
    in counts, times in seconds; nothing here knows about CAN or degrees.

    Attributes:
        t0: Start time.
        p0: Position at *t0*.
        v0: Velocity at *t0*.
        segments: ``(duration, acceleration)`` pairs, in order.
        final_position: For moves, the exact target (avoids rounding drift at rest).
    """

    t0: float
    p0: float
    v0: float = 0.0
    segments: tuple[tuple[float, float], ...] = ()
    final_position: float | None = None
    _ends: tuple[float, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        ends, t = [], self.t0
        for duration, _ in self.segments:
            t += duration
            ends.append(t)
        object.__setattr__(self, "_ends", tuple(ends))

    @classmethod
    def rest(cls, t0: float, position: float) -> Trajectory:
        """A trajectory that stays at *position*."""
        return cls(t0, position, 0.0, (), position)

    @property
    def end_time(self) -> float:
        """When the last segment ends (the axis then cruises or rests)."""
        return self._ends[-1] if self._ends else self.t0

    @property
    def final_velocity(self) -> float:
        """The velocity after the last segment."""
        return self.v0 + sum(d * a for d, a in self.segments)

    def state_at(self, t: float) -> tuple[float, float, float]:
        """Return (position, velocity, acceleration) at time *t* (clamped to ``t >= t0``)."""
        p, v = self.p0, self.v0
        start = self.t0
        if t <= start:
            return p, v, 0.0
        for (duration, accel), end in zip(self.segments, self._ends, strict=True):
            if t < end:
                dt = t - start
                return p + v * dt + 0.5 * accel * dt * dt, v + accel * dt, accel
            p += v * duration + 0.5 * accel * duration * duration
            v += accel * duration
            start = end
        if abs(v) < _VEL_EPS:
            return (p if self.final_position is None else self.final_position), 0.0, 0.0
        return p + v * (t - start), v, 0.0

    def is_moving(self, t: float) -> bool:
        """Whether the axis moves at time *t*."""
        return t < self.end_time or abs(self.final_velocity) >= _VEL_EPS

    def first_reach(self, level: float, direction: int, t_from: float, t_to: float) -> float | None:
        """Return the first time in ``[t_from, t_to]`` where the position reaches *level*.

        Args:
            level: The position to watch (a limit switch).
            direction: +1 to watch upward crossings (position becomes >= level),
                -1 for downward ones.
            t_from: Start of the window; the position is assumed on the near side there.
            t_to: End of the window.
        """
        pieces: list[tuple[float, float, float, float, float]] = []  # start, end, p, v, a
        p, v, start = self.p0, self.v0, self.t0
        for (duration, accel), end in zip(self.segments, self._ends, strict=True):
            pieces.append((start, end, p, v, accel))
            p += v * duration + 0.5 * accel * duration * duration
            v += accel * duration
            start = end
        pieces.append((start, math.inf, p, v if abs(v) >= _VEL_EPS else 0.0, 0.0))
        for start, end, p, v, accel in pieces:
            lo, hi = max(start, t_from), min(end, t_to)
            if lo > hi:
                continue
            # Solve direction * (p + v*s + a/2*s^2 - level) >= 0 for the smallest s in [lo-start, hi-start].
            s = _first_root(direction * (p - level), direction * v, direction * 0.5 * accel, lo - start, hi - start)
            if s is not None:
                return start + s
        return None


def _first_root(c: float, b: float, a: float, s_lo: float, s_hi: float) -> float | None:
    """Smallest s in [s_lo, s_hi] with a*s^2 + b*s + c >= 0, or None."""
    if a * s_lo * s_lo + b * s_lo + c >= 0:
        return s_lo
    roots: list[float] = []
    if abs(a) < _EPS:
        if abs(b) > _EPS:
            roots.append(-c / b)
    else:
        disc = b * b - 4 * a * c
        if disc >= 0:
            sq = math.sqrt(disc)
            roots.extend(((-b - sq) / (2 * a), (-b + sq) / (2 * a)))
    for root in sorted(roots):
        if s_lo <= root <= s_hi:
            return root
    return None


def _segments_to_rest_move(distance: float, u: float, speed: float, acc: float,
                           dec: float) -> list[tuple[float, float]]:
    """Segments (in the direction frame) from velocity u >= 0 to rest after *distance*.

    Assumes the stopping distance ``u²/2dec`` does not exceed *distance*.
    """
    if u > speed:
        cruise = (distance - u * u / (2 * dec)) / speed
        return [((u - speed) / dec, -dec), (max(cruise, 0.0), 0.0), (speed / dec, -dec)]
    d_acc = (speed * speed - u * u) / (2 * acc)
    d_dec = speed * speed / (2 * dec)
    if d_acc + d_dec <= distance:
        return [((speed - u) / acc, acc), ((distance - d_acc - d_dec) / speed, 0.0), (speed / dec, -dec)]
    peak = math.sqrt(max((distance + u * u / (2 * acc)) / (1 / (2 * acc) + 1 / (2 * dec)), u * u))
    return [((peak - u) / acc, acc), (peak / dec, -dec)]


def plan_move(
    t0: float, position: float, velocity: float, target: float, speed: float, acc: float, dec: float
) -> Trajectory:
    """Plan a point-to-point move (Elmo PTP profile) from any initial velocity.

    The axis accelerates with *acc* up to *speed*, cruises and decelerates with
    *dec* to stop on *target*; if it is moving away from the target, or too fast
    to stop before it, it first decelerates to rest and comes back.

    Args:
        t0: Start time.
        position: Position at *t0*.
        velocity: Velocity at *t0*.
        target: The final position.
        speed: Cruise speed (> 0).
        acc: Acceleration (> 0).
        dec: Deceleration (> 0).
    """
    if speed <= 0 or acc <= 0 or dec <= 0:
        raise ValueError("speed, acceleration and deceleration must be positive")
    segments: list[tuple[float, float]] = []
    p, v = position, velocity
    direction = 1.0 if target > p else -1.0
    u = direction * v
    if u < -_EPS or (u > _EPS and u * u / (2 * dec) > abs(target - p)):
        # Brake to rest first, then plan from there.
        brake = abs(v) / dec
        accel = -math.copysign(dec, v)
        segments.append((brake, accel))
        p += v * brake + 0.5 * accel * brake * brake
        v = 0.0
        direction = 1.0 if target > p else -1.0
        u = 0.0
    distance = abs(target - p)
    if distance > _EPS:
        for duration, accel in _segments_to_rest_move(distance, max(u, 0.0), speed, acc, dec):
            if duration > _EPS:
                segments.append((duration, direction * accel))
    return Trajectory(t0, position, velocity, tuple(segments), target)


def plan_jog(t0: float, position: float, velocity: float, target_velocity: float, acc: float, dec: float) -> Trajectory:
    """Plan a jog: reach *target_velocity* (AC when speeding up, DC when slowing) and keep it."""
    if acc <= 0 or dec <= 0:
        raise ValueError("acceleration and deceleration must be positive")
    segments: list[tuple[float, float]] = []
    v = velocity
    if v * target_velocity < 0 or (abs(target_velocity) < abs(v)):
        # Slow down (to zero when reversing) with the deceleration.
        stop_at = 0.0 if v * target_velocity < 0 else target_velocity
        segments.append((abs(v - stop_at) / dec, math.copysign(dec, stop_at - v)))
        v = stop_at
    if abs(target_velocity - v) > _EPS:
        segments.append((abs(target_velocity - v) / acc, math.copysign(acc, target_velocity - v)))
    kept = tuple(seg for seg in segments if seg[0] > _EPS)
    return Trajectory(t0, position, velocity, kept, None)


def plan_stop(t0: float, position: float, velocity: float, dec: float) -> Trajectory:
    """Plan a stop with deceleration *dec* from the current velocity."""
    if abs(velocity) < _EPS:
        return Trajectory.rest(t0, position)
    duration = abs(velocity) / dec
    return Trajectory(t0, position, velocity, ((duration, -math.copysign(dec, velocity)),), None)


def move_duration(distance: float, speed: float, acc: float, dec: float) -> float:
    """Duration of a move of *distance* from rest to rest (for timeouts and tests)."""
    return plan_move(0.0, 0.0, 0.0, abs(distance), speed, acc, dec).end_time
