"""Issue 31's experiment, reduced: two talkers in the 0.6 s room on the KEMAR, one on the snowman head.

The goals of the issue hold on the KEMAR (talkers within 5 degrees with a planned turn, no front/back
confusion, the still head no worse than the localiser of before); on the snowman head the front/back goal holds
with the turn (the room filter of a head that turns weighs the templates' front/back preference little), the
within-5-degrees goal does not (docs/localisation.md says by how much: the snowman's lateral angles are off by up
to 8 degrees). Seeds of their own (the documented run uses 31). Seconds, not minutes.
"""

from __future__ import annotations

import pytest

from aiogenomix.components.binaural.talkers_experiment import (
    TEST_ROOMS, TalkersConfig, _path, match_talkers, run_talkers, summarise_talkers,
)


def test_two_talkers_in_a_reverberant_room_on_the_templates_head_meet_the_goals() -> None:
    config = TalkersConfig(rooms=(TEST_ROOMS[2],), heads=("kemar",), talkers=(2,), cases=3, seed=3101,
                           strategies=("today", "still", "filter"))
    results, timing = run_talkers(config)
    summaries = {s.strategy: s for s in summarise_talkers(results)}
    assert [(s.room, s.head, s.talkers, s.cases) for s in summaries.values()] == [("B (0.6 s)", "kemar", 2, 3)] * 3
    assert summaries["filter"].within_5 >= 0.95 and summaries["filter"].front_back <= 0.02, summaries["filter"]
    assert summaries["still"].within_5 >= summaries["today"].within_5, summaries
    assert summaries["filter"].count_right >= 2 / 3, summaries["filter"]
    # Every case's turn was planned, and heard: its audio counts as the still head's does.
    assert all(len(r.turns["filter"]) == 1 and r.turns["filter"][0] != 0.0 for r in results)
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


def test_a_turn_not_over_when_the_next_begins_leaves_the_head_where_it_was() -> None:
    # 60 degrees at 90 degrees/s takes 0.67 s; the next turn comes after 0.5 s, from 45 degrees.
    path = _path([(0.5, 60.0), (1.0, 20.0)], 0.0, 90.0)
    azimuths = [path(t / 100) for t in range(0, 201)]
    assert max(abs(b - a) for a, b in zip(azimuths, azimuths[1:], strict=False)) <= 0.9 + 1e-9
    assert path(1.0) == pytest.approx(45.0) and path(2.0) == pytest.approx(20.0)
