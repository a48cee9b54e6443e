"""Issue 31's experiment, reduced: one to three talkers in the three rooms on the KEMAR, a few on the snowman head.

The goals of the issue hold on the KEMAR (talkers within 5 degrees with planned turns, front/back confusions,
the still head no worse than the localiser of before); on the snowman head the front/back goal holds with the
turns for one and two talkers (the room filter of a head that turns weighs the templates' front/back preference
little), the within-5-degrees goal does not (docs/localisation.md says by how much: the snowman's lateral angles
are off by up to 8 degrees). Seeds of their own (the documented run uses 31). Seconds, not minutes.
"""

from __future__ import annotations

import pytest

from aiogenomix.components.binaural.talkers_experiment import (
    KEMAR_ACCELERATION, TEST_ROOMS, TalkersConfig, _path, match_talkers, run_talkers, summarise_talkers, turn_time,
    turning_head,
)


def test_one_to_three_talkers_in_the_reverberant_rooms_on_the_templates_head_meet_the_goals() -> None:
    config = TalkersConfig(rooms=TEST_ROOMS[1:], heads=("kemar",), talkers=(1, 2, 3), cases=2, seed=3101,
                           strategies=("today", "still", "filter"))
    results, timing = run_talkers(config)
    summaries = summarise_talkers(results)
    assert {(s.room, s.head, s.cases) for s in summaries} == {(room.name, "kemar", 2) for room in TEST_ROOMS[1:]}

    def pooled(strategy: str, talkers: int, measure: str) -> float:
        """The measure over the three rooms (each room's cases alike, so the plain mean)."""
        return sum(getattr(s, measure) for s in summaries if (s.strategy, s.talkers) == (strategy, talkers)) / 3

    for talkers, goal in ((1, 0.98), (2, 0.95), (3, 0.90)):
        assert pooled("filter", talkers, "within_5") >= goal, (talkers, summaries)
        assert pooled("filter", talkers, "front_back") <= 0.02, (talkers, summaries)
        assert pooled("filter", talkers, "count_right") >= 2 / 3, (talkers, summaries)
        assert pooled("still", talkers, "within_5") >= pooled("today", talkers, "within_5"), (talkers, summaries)
    # A turn was planned after each look but the last, and heard: its audio counts as the still head's does.
    assert all(len(r.turns["filter"]) == round(1.0 / config.look) - 1 > 0 and r.turns["filter"][0] != 0.0
               for r in results)
    assert timing.audio > 0 and timing.localise > 0


def test_on_a_head_the_templates_never_saw_the_turn_tells_front_from_back() -> None:
    config = TalkersConfig(rooms=(TEST_ROOMS[1],), heads=("snowman",), talkers=(1,), cases=4, seed=3102,
                           strategies=("still", "filter"))
    results, _ = run_talkers(config)
    summaries = {s.strategy: s for s in summarise_talkers(results)}
    assert summaries["filter"].front_back <= summaries["still"].front_back, summaries
    for result in results:
        errors, _ = match_talkers(result.azimuths, result.estimates["filter"])
        # Never its mirror image: within 10 degrees of the talker (the snowman's lateral angles are off by up to 7).
        assert errors[0] <= 10.0, result


def test_on_a_head_the_templates_never_saw_two_talkers_in_a_room_are_told_from_their_mirror_images() -> None:
    config = TalkersConfig(rooms=(TEST_ROOMS[2],), heads=("snowman",), talkers=(2,), cases=3, seed=3103,
                           strategies=("still", "filter"))
    results, _ = run_talkers(config)
    summaries = {s.strategy: s for s in summarise_talkers(results)}
    # The goal (front/back confusions at most 2 %) with the turn; the still head confuses them.
    assert summaries["filter"].front_back <= 0.02 < summaries["still"].front_back, summaries
    assert summaries["filter"].within_10 >= 0.8, summaries


def test_a_configuration_names_heads_it_has() -> None:
    with pytest.raises(ValueError, match="kemar or snowman"):
        run_talkers(TalkersConfig(heads=("dummy",), cases=1))


def test_a_turn_speeds_up_and_slows_down_as_the_kemars_drive_does() -> None:
    # 60 degrees at up to 90 degrees/s: 0.06 s to reach that speed (2.8 degrees), 0.61 s at it, 0.06 s to stop.
    turn = turning_head(10.0, 70.0, 0.5, 90.0, KEMAR_ACCELERATION)
    step = 1e-3
    azimuths = [turn(0.5 + k * step) for k in range(-100, 1001)]
    speeds = [(b - a) / step for a, b in zip(azimuths, azimuths[1:], strict=False)]
    changes = [(b - a) / step for a, b in zip(speeds, speeds[1:], strict=False)]
    assert azimuths[0] == 10.0 and azimuths[100] == 10.0 and azimuths[-1] == 70.0
    assert max(speeds) == pytest.approx(90.0, abs=1e-6) and min(speeds) >= 0.0
    assert max(abs(c) for c in changes) <= KEMAR_ACCELERATION * 1.01
    took = turn_time(60.0, 90.0, KEMAR_ACCELERATION)
    assert took == pytest.approx(60.0 / 90.0 + 90.0 / KEMAR_ACCELERATION)
    assert turn(0.5 + took - 0.01) < 70.0 == turn(0.5 + took)
    # A turn too short to reach the speed: half the way speeding up, half slowing down, and the other way round.
    short = turning_head(0.0, -4.0, 0.0, 90.0, KEMAR_ACCELERATION)
    assert turn_time(4.0, 90.0, KEMAR_ACCELERATION) == pytest.approx(2 * (4.0 / KEMAR_ACCELERATION) ** 0.5)
    assert short(turn_time(4.0, 90.0, KEMAR_ACCELERATION) / 2) == pytest.approx(-2.0)


def test_a_turn_not_over_when_the_next_begins_leaves_the_head_where_it_was() -> None:
    # 60 degrees at 90 degrees/s takes 0.67 s; the next turn comes after 0.5 s, from 45 degrees.
    path = _path([(0.5, 60.0), (1.0, 20.0)], 0.0, 90.0)
    azimuths = [path(t / 100) for t in range(0, 201)]
    assert max(abs(b - a) for a, b in zip(azimuths, azimuths[1:], strict=False)) <= 0.9 + 1e-9
    assert path(1.0) == pytest.approx(45.0) and path(2.0) == pytest.approx(20.0)
