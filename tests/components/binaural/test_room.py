"""Rooms: a 6 × 4 × 3 m shoebox against Eyring and an independent simulator, its reflections against the geometry.

The reverberation times are measured on the rendered binaural room responses as a
researcher measures a room's: Schroeder backward integration, T20, octave bands of
500 Hz to 4 kHz. The independent simulator is pyroomacoustics (its image sources
to order 3 and ray tracing with scattering, averaged over four microphones), which
shares no code or formula with ours.
"""

from __future__ import annotations

import os

import numpy as np
import pytest
from scipy import signal

from aiogenomix.components.binaural import (
    HrirSet, Pose, RoomRenderer, Shoebox, band_ilds, gcc_phat_itd, image_sources, room_response,
    third_octave_centres,
)

DIMENSIONS = (6.0, 4.0, 3.0)
SOURCE = (1.5, 1.2, 1.4)
LISTENER = Pose(4.2, 2.7, 1.6, facing=170.0)
#: Energy absorption of every wall: Eyring's RT60 0.66, 0.37 and 0.21 s.
ABSORPTIONS = (0.15, 0.25, 0.4)
BANDS = (500.0, 1000.0, 2000.0, 4000.0)


def t20(responses: list[np.ndarray], rate: float, centre: float) -> float:
    """T20 of the octave band at *centre*: the responses' Schroeder integrals, averaged, fitted from −5 to −25 dB."""
    sos = signal.butter(4, [centre / np.sqrt(2), centre * np.sqrt(2)], "bandpass", fs=rate, output="sos")
    length = min(len(r) for r in responses)
    decay = np.zeros(length)
    for response in responses:
        energy = np.cumsum(signal.sosfiltfilt(sos, response[:length])[::-1] ** 2)[::-1]
        decay += energy / energy[0]
    level = 10 * np.log10(decay / decay[0])
    first, last = int(np.argmax(level <= -5.0)), int(np.argmax(level <= -25.0))
    slope = np.polyfit(np.arange(first, last) / rate, level[first:last], 1)[0]
    return float(-60.0 / slope)


def probe(rate: float = 44_100.0) -> HrirSet:
    """Two point microphones at the head's centre: every direction's response is one unit sample."""
    azimuth = np.tile(np.arange(-180.0, 180.0, 10.0), 7)
    elevation = np.repeat(np.arange(-90.0, 91.0, 30.0), 36)
    taps = np.zeros((len(azimuth), 64, 2))
    taps[:, 0, :] = 1.0
    return HrirSet(rate, azimuth, elevation, taps, "probe")


def test_eyring_and_a_room_given_by_its_rt60() -> None:
    room = Shoebox.with_absorption(DIMENSIONS, 0.25)
    assert room.volume == 72.0 and room.surface == 108.0
    assert room.eyring_rt60() == pytest.approx(0.1611 * 72 / (-108 * np.log(0.75)), rel=1e-3)
    again = Shoebox.with_rt60(DIMENSIONS, [0.9, 0.8, 0.7, 0.6, 0.5, 0.4, 0.3])
    assert again.eyring_rt60() == pytest.approx([0.9, 0.8, 0.7, 0.6, 0.5, 0.4, 0.3])
    walls = Shoebox.with_absorption(DIMENSIONS, {"floor": 0.5, "ceiling": 0.7, "walls": 0.1})
    assert walls.mean_absorption()[0] == pytest.approx((24 * 0.5 + 24 * 0.7 + 60 * 0.1) / 108)


@pytest.mark.parametrize("bad", [{"dimensions": (6, 4)}, {"dimensions": (6, -4, 3)}, {"absorption": 0.0},
                                 {"absorption": 1.5}, {"absorption": [0.1, 0.2]}, {"absorption": {"roof": 0.2}}])
def test_a_room_that_makes_no_sense_is_refused_by_name(bad: dict) -> None:
    from aiogenomix.components.binaural import BinauralError

    arguments = {"dimensions": DIMENSIONS, "absorption": 0.2} | bad
    with pytest.raises(BinauralError):
        Shoebox.with_absorption(arguments["dimensions"], arguments["absorption"])


def test_the_reflections_arrive_when_the_geometry_says_within_one_sample() -> None:
    rate = 44_100.0
    room = Shoebox.with_absorption(DIMENSIONS, 0.3)
    response = room_response(SOURCE, LISTENER, rate=rate, seconds=0.12, room=room, hrirs=probe(rate), max_order=1,
                             mixing_time=0.1)[:, 0]
    images = image_sources(room, SOURCE, LISTENER.position, max_order=1)
    expected = images.delays(room.speed_of_sound) * rate
    assert len(expected) == 7
    # The peaks before the tail fades in (at 95 ms): the direct sound and the six first reflections (the
    # floor's and the ceiling's arrive together: source and listener are as far above the floor as below the ceiling).
    early = np.abs(response[:int(0.094 * rate)])
    peaks, _ = signal.find_peaks(early, height=0.05 * early.max(), distance=3)
    arrivals, together = np.unique(np.round(expected), return_inverse=True)
    assert len(peaks) == len(arrivals) == 6
    assert np.max(np.abs(peaks - expected[np.searchsorted(np.round(expected), arrivals)])) <= 1.0
    # Each at 1/r times its wall's √(1 − α).
    gains = np.bincount(together, images.gains[:, 0])
    assert early[peaks] == pytest.approx(gains, rel=0.05)


def test_the_direct_sound_has_the_hrirs_itd_and_ild(kemar: HrirSet) -> None:
    rate = 44_100.0
    room = Shoebox.with_absorption(DIMENSIONS, 0.25)
    listener = Pose(3.0, 2.0, 1.5, facing=20.0)
    source = listener.at(20.0 + 60.0, distance=1.0)          # 60° to the left of the nose, at ear height
    response = room_response(source, listener, rate=rate, seconds=0.05, room=room, hrirs=kemar)
    measured = kemar.taps[kemar.index(60.0)]
    arrival = int(1.0 / room.speed_of_sound * rate)
    # The same 4 ms of both, from their onsets: the direct sound before the first reflection.
    window = np.hanning(2 * 176)[176:]
    direct = response[arrival:arrival + 176] * window[:, np.newaxis]
    onset = int(np.argmax(np.abs(measured).max(axis=1) > 0.05 * np.abs(measured).max()))
    reference = measured[onset - 4:onset - 4 + 176] * window[:, np.newaxis]
    assert abs(gcc_phat_itd(*direct.T, max_lag=50) - gcc_phat_itd(*reference.T, max_lag=50)) <= 1.0
    centres = third_octave_centres(1000.0, 16_000.0)
    difference = band_ilds(*direct.T, rate, centres) - band_ilds(*reference.T, rate, centres)
    assert np.sqrt(np.mean(difference**2)) <= 2.0


def largest_jump(ears: np.ndarray) -> float:
    return float(np.max(np.abs(np.diff(ears, axis=0))))


def test_a_head_sweep_in_a_reverberant_room_has_no_click(kemar: HrirSet) -> None:
    rate, chunk, chunks = 44_100.0, 1024, 12
    room = Shoebox.with_absorption(DIMENSIONS, 0.4)
    listener = Pose(3.0, 2.0, 1.5)
    tone = 0.5 * np.sin(2 * np.pi * 125.0 * np.arange(chunk * chunks) / rate)[np.newaxis]
    heads = np.arange(1, chunks + 1) * 180.0 * chunk / rate
    source = [listener.at(60.0, distance=1.5)]

    def render(head_of) -> np.ndarray:
        renderer = RoomRenderer(rate, 1, hrirs=kemar, room=room, seed=3)
        return np.concatenate([renderer.render(tone[:, i * chunk:(i + 1) * chunk], head_of(i), source,
                                               listener.position) for i in range(chunks)])

    sweep = render(lambda i: heads[i])
    statics = {head: render(lambda _i, head=head: head) for head in np.concatenate([[0.0], heads])}
    skip = 2048   # the room's build-up
    bound = 1.1 * max(largest_jump(ears[skip:]) for ears in statics.values())
    assert largest_jump(sweep[skip:]) <= bound
    # The same sweep with the responses switched at the chunks' edges clicks.
    switched = np.concatenate([statics[heads[i]][i * chunk:(i + 1) * chunk] for i in range(chunks)])
    assert largest_jump(switched[skip:]) > 1.5 * bound


def direct_to_reverberant(response: np.ndarray, arrival: float, rate: float) -> float:
    """DRR in dB: the energy within 2.5 ms of the direct sound's arrival against all that comes after."""
    half, at = int(0.0025 * rate), int(round(arrival))
    return float(10 * np.log10(np.sum(response[max(0, at - half):at + half] ** 2) / np.sum(response[at + half:] ** 2)))


def test_the_rt60_is_eyrings_and_pyroomacoustics_within_10_percent_and_the_drr_theirs(kemar: HrirSet) -> None:
    pra = pytest.importorskip("pyroomacoustics", reason="pyroomacoustics (the dev extra) is the independent simulator")
    rate = 16_000.0
    microphones = np.array([LISTENER.position, (4.5, 1.2, 1.2), (2.5, 3.0, 1.8), (5.0, 2.0, 1.4)])
    # The independent simulator traces rays drawn at random, from its own seeded generator. Seconds a room:
    # every room on one Python, the one of middle absorption on the others (AIOGENOMIX_HEAVY=0).
    pra.random.seed(1)
    absorptions = ABSORPTIONS if os.environ.get("AIOGENOMIX_HEAVY") != "0" else ABSORPTIONS[1:2]
    for alpha in absorptions:
        room = Shoebox.with_absorption(DIMENSIONS, alpha)
        eyring = float(room.eyring_rt60()[2])
        seconds = 1.2 * eyring + 0.1
        ours = [room_response(SOURCE, Pose(*position, facing=170.0), rate=rate, seconds=seconds, room=room,
                              hrirs=kemar, seed=i) for i, position in enumerate(microphones)]
        responses = [r[:, ear] for r in ours for ear in (0, 1)]
        simulated = pra.ShoeBox(list(DIMENSIONS), fs=int(rate), materials=pra.Material(alpha, 0.3), max_order=3,
                                air_absorption=False, ray_tracing=True)
        simulated.set_ray_tracing(receiver_radius=0.5, n_rays=10_000, energy_thres=1e-7)
        simulated.add_source(list(SOURCE))
        simulated.add_microphone_array(microphones.T)
        simulated.compute_rir()
        theirs = [np.asarray(simulated.rir[m][0]) for m in range(len(microphones))]
        for centre in BANDS:
            mine, other = t20(responses, rate, centre), t20(theirs, rate, centre)
            assert mine == pytest.approx(eyring, rel=0.10), (alpha, centre, mine, eyring)
            assert mine == pytest.approx(other, rel=0.10), (alpha, centre, mine, other)
        # The direct-to-reverberant ratio at two point microphones (their simulator's receivers are omnidirectional),
        # averaged over the four places: within 1 dB of theirs (single places differ by up to 2.6 dB).
        distances = np.linalg.norm(microphones - np.asarray(SOURCE), axis=1)
        omni = [room_response(SOURCE, Pose(*position), rate=rate, seconds=seconds, room=room, hrirs=probe(rate),
                              seed=i)[:, 0] for i, position in enumerate(microphones)]
        arrivals = distances / 343.0 * rate
        mine_drr = np.mean([direct_to_reverberant(r, a, rate) for r, a in zip(omni, arrivals, strict=True)])
        peaks = [int(np.argmax(np.abs(r[:int(a + 0.01 * rate)]))) for r, a in zip(theirs, arrivals, strict=True)]
        their_drr = np.mean([direct_to_reverberant(r, p, rate) for r, p in zip(theirs, peaks, strict=True)])
        assert mine_drr == pytest.approx(their_drr, abs=1.0), (alpha, mine_drr, their_drr)
