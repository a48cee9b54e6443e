"""Offline scenes: distance, several talkers, paths, voices and the head's motion."""

from __future__ import annotations

import numpy as np
import pytest

from aiogenomix.components.binaural import (
    VOICES, BinauralError, HrirSet, Path, Pose, Shoebox, Talker, gcc_phat_itd, render_scene, speech_like,
)

RATE = 44_100.0


def test_distance_gives_delay_and_one_over_r(kemar: HrirSet) -> None:
    listener = Pose(0.0, 0.0, 1.5)
    click = np.zeros(4410)
    click[0] = 1.0
    # Distances of whole samples of travel (128 and 440): a fractional delay is read by cubic interpolation,
    # which dulls the top octave a little, in both ears alike.
    metres = 343.0 / RATE
    near = render_scene([Talker(click, listener.at(0.0, distance=128 * metres))], listener, rate=RATE,
                        seconds=0.1, hrirs=kemar)
    far = render_scene([Talker(click, listener.at(0.0, distance=440 * metres))], listener, rate=RATE,
                       seconds=0.1, hrirs=kemar)
    # 312 samples (7.07 ms, 2.43 m) later, at 128/440 of the amplitude.
    assert np.argmax(np.abs(far[:, 0])) - np.argmax(np.abs(near[:, 0])) == 312
    assert np.sqrt(np.sum(far**2) / np.sum(near**2)) == pytest.approx(128 / 440, rel=1e-6)


def test_talkers_add_up_each_with_its_level_and_onset(kemar: HrirSet) -> None:
    room = Shoebox.with_rt60((6.0, 4.0, 3.0), 0.3)
    listener = Pose(3.0, 2.0, 1.5)
    rng = np.random.default_rng(4)
    one, two = speech_like(1.0, RATE, rng), speech_like(1.0, RATE, rng, voice="female")
    talkers = [Talker(one, listener.at(40.0, distance=1.2)), Talker(two, listener.at(-120.0, distance=2.0),
                                                                      level=-6.0, onset=0.25)]
    both = render_scene(talkers, listener, rate=RATE, seconds=1.0, room=room, hrirs=kemar)
    silent = [Talker(np.zeros(1), t.position) for t in talkers]
    first = render_scene([talkers[0], silent[1]], listener, rate=RATE, seconds=1.0, room=room, hrirs=kemar)
    second = render_scene([silent[0], talkers[1]], listener, rate=RATE, seconds=1.0, room=room, hrirs=kemar)
    assert np.allclose(both, first + second, atol=1e-12)
    assert not np.any(second[:int(0.25 * RATE)])
    assert np.any(second[int(0.26 * RATE):])


def test_a_talker_walks_its_path_at_its_speed() -> None:
    path = Path(((0.0, 0.0, 1.5), (3.0, 0.0, 1.5), (3.0, 4.0, 1.5)), speed=1.0)
    assert path.position(1.5) == pytest.approx((1.5, 0.0, 1.5))
    assert path.position(5.0) == pytest.approx((3.0, 2.0, 1.5))
    assert path.position(60.0) == pytest.approx((3.0, 4.0, 1.5))
    looped = Path(((0.0, 0.0, 1.5), (1.0, 0.0, 1.5)), speed=0.5, loop=True)
    assert looped.position(5.0) == pytest.approx((0.5, 0.0, 1.5))
    with pytest.raises(BinauralError):
        Path((), speed=1.0)


def test_a_moving_talker_is_heard_moving(kemar: HrirSet) -> None:
    listener = Pose(0.0, 0.0, 1.5)
    noise = np.random.default_rng(5).standard_normal(int(2 * RATE))
    walker = Path((listener.at(80.0, distance=1.5), listener.at(-80.0, distance=1.5)), speed=1.5)
    ears = render_scene([Talker(noise, walker)], listener, rate=RATE, seconds=2.0, hrirs=kemar)
    start, end = ears[4410:13230], ears[-13230:-4410]
    assert gcc_phat_itd(*start.T, max_lag=50) > 15 and gcc_phat_itd(*end.T, max_lag=50) < -15


def test_a_turning_head_hears_a_fixed_talker_turn_the_other_way(kemar: HrirSet) -> None:
    listener = Pose(0.0, 0.0, 1.5)
    noise = np.random.default_rng(6).standard_normal(int(RATE))
    ears = render_scene([Talker(noise, listener.at(0.0, distance=2.0))], listener, rate=RATE, seconds=1.0,
                        hrirs=kemar, head=lambda t: -60.0 * t)
    # At the end the head faces -60°: the talker is 60° to its left.
    assert gcc_phat_itd(*ears[-8820:].T, max_lag=50) == pytest.approx(
        gcc_phat_itd(*kemar.taps[kemar.index(57.0)].T, max_lag=50), abs=2.0)


def test_voices_differ_in_pitch_and_a_wrong_voice_is_refused() -> None:
    def pitch(x: np.ndarray) -> float:
        spectrum = np.abs(np.fft.rfft(x * np.hanning(len(x))))
        freqs = np.fft.rfftfreq(len(x), 1 / RATE)
        band = (freqs > 60) & (freqs < 400)
        return float(freqs[band][np.argmax(spectrum[band])])

    male = speech_like(2.0, RATE, np.random.default_rng(1))
    female = speech_like(2.0, RATE, np.random.default_rng(1), voice="female")
    assert pitch(female) > 1.4 * pitch(male)
    assert set(VOICES) == {"male", "female", "child"}
    with pytest.raises(ValueError, match="voice"):
        speech_like(1.0, RATE, np.random.default_rng(1), voice="robot")


def test_a_source_outside_the_room_is_refused() -> None:
    room = Shoebox.with_absorption((6.0, 4.0, 3.0), 0.2)
    with pytest.raises(BinauralError, match="outside the room"):
        render_scene([Talker(np.ones(10), (7.0, 1.0, 1.0))], Pose(3.0, 2.0, 1.5), rate=RATE, seconds=0.01, room=room)
