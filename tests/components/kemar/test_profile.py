"""Trapezoidal profiles: speed and acceleration limits, exact end points, limit crossings."""

from __future__ import annotations

import pytest

from aiogenomix.components.kemar._profile import Trajectory, move_duration, plan_jog, plan_move, plan_stop

SPEED, ACC, DEC = 20480.0, 300000.0, 300000.0


def samples(trajectory: Trajectory, steps: int = 400) -> list[tuple[float, float, float]]:
    end = trajectory.end_time + 0.1
    return [trajectory.state_at(trajectory.t0 + end * i / steps) for i in range(steps + 1)]


@pytest.mark.parametrize("distance", [6144.0, -6144.0, 100.0, 40000.0])
def test_move_respects_speed_and_acceleration_and_ends_on_target(distance: float) -> None:
    move = plan_move(1.0, 500.0, 0.0, 500.0 + distance, SPEED, ACC, DEC)
    for _, velocity, acceleration in samples(move):
        assert abs(velocity) <= SPEED + 1e-6
        assert abs(acceleration) <= max(ACC, DEC)
    assert move.state_at(move.end_time + 5) == (500.0 + distance, 0.0, 0.0)
    assert not move.is_moving(move.end_time + 1e-9)


def test_duration_of_a_trapezoid() -> None:
    # 30 deg at 100 deg/s: 2 x 0.0683 s ramps + cruise of the rest.
    ramp = SPEED / ACC
    expected = 2 * ramp + (6144 - SPEED * ramp) / SPEED
    assert move_duration(6144, SPEED, ACC, DEC) == pytest.approx(expected)


def test_short_move_is_triangular() -> None:
    move = plan_move(0.0, 0.0, 0.0, 100.0, SPEED, ACC, DEC)
    peak = max(v for _, v, _ in samples(move))
    assert peak < SPEED
    assert move.end_time == pytest.approx(2 * (100 / ACC) ** 0.5)


def test_move_from_motion_away_from_the_target_brakes_and_comes_back() -> None:
    move = plan_move(0.0, 0.0, SPEED, -1000.0, SPEED, ACC, DEC)
    furthest = max(p for p, _, _ in samples(move))
    assert furthest == pytest.approx(SPEED**2 / (2 * DEC), rel=1e-3)
    assert move.state_at(10.0)[0] == -1000.0


def test_jog_reaches_and_keeps_its_velocity() -> None:
    jog = plan_jog(0.0, 0.0, -5000.0, 10000.0, ACC, DEC)
    assert jog.state_at(10.0)[1] == pytest.approx(10000.0)
    assert jog.is_moving(100.0)
    assert jog.end_time == pytest.approx(5000 / DEC + 10000 / ACC)


def test_stop_decelerates_to_rest() -> None:
    stop = plan_stop(0.0, 0.0, 20000.0, 1e6)
    assert stop.state_at(1.0) == (pytest.approx(200.0), 0.0, 0.0)
    assert not stop.is_moving(1.0)


def test_first_reach_finds_the_crossing_time() -> None:
    jog = plan_jog(0.0, 0.0, 0.0, 10000.0, ACC, DEC)
    hit = jog.first_reach(18432.0, +1, 0.0, 100.0)
    assert hit is not None and jog.state_at(hit)[0] == pytest.approx(18432.0)
    assert jog.first_reach(18432.0, +1, 0.0, 1.0) is None
    assert jog.first_reach(-10.0, -1, 0.0, 100.0) is None
