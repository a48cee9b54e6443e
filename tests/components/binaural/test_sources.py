"""Several sources: glimpses placed in the room by the head's azimuth, explained by a mixture over room azimuth."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aiogenomix.components.binaural import (
    GRID_DEGREES, BinauralRenderer, Glimpses, HrirSet, LocalisationError, LocaliserSetup, RoomAzimuthFilter,
    SourceCounting, SourceLocaliser, erb_bands, mirror_image, pick_sources, speech_like, tempered, wrap_degrees,
)

RATE = 24_414.0


@pytest.fixture(scope="module")
def localiser(kemar: HrirSet) -> SourceLocaliser:
    return SourceLocaliser(LocaliserSetup(rate=RATE), hrirs=kemar)


def talkers(kemar: HrirSet, azimuths: list[float], head: float | list[float], seconds: float,
            seed: int) -> np.ndarray:
    """Speech-like talkers at room *azimuths* heard by a head at *head* (one azimuth per second when a list)."""
    dry = np.stack([0.1 * speech_like(seconds, RATE, np.random.default_rng([seed, k])) for k in range(len(azimuths))])
    renderer = BinauralRenderer(RATE, len(azimuths), hrirs=kemar, diffuse_level=-20.0 - 20.0, seed=seed)
    heads = head if isinstance(head, list) else [head]
    second = len(dry[0]) // len(heads)
    pieces = []
    for k, h in enumerate(heads):
        renderer.render(dry[:, :0], h, azimuths)      # the head turns at once (no frame rendered)
        pieces.append(renderer.render(dry[:, k * second:(k + 1) * second], h, azimuths))
    return np.concatenate(pieces)


def near(found: list[float], truth: list[float], tolerance: float = 5.0) -> bool:
    return all(min(abs(float(wrap_degrees(f - t))) for f in found) <= tolerance for t in truth)


def test_bands_are_one_erb_wide() -> None:
    frequencies = np.fft.rfftfreq(1024, 1 / RATE)[5:210]
    bands = erb_bands(frequencies)
    assert np.concatenate(bands).tolist() == list(range(len(frequencies)))
    # Each band spans at most one ERB (Glasberg & Moore: 24.7 (4.37 f/kHz + 1) Hz at its lowest frequency
    # and more above): the lowest hold a bin or two 24 Hz apart, the highest many.
    for band in bands:
        low, high = frequencies[band[0]], frequencies[band[-1]]
        assert high - low <= 24.7 * (4.37 * high / 1000 + 1)
    assert len(bands[0]) <= 2 and len(bands[-2]) > 10 and 20 <= len(bands) <= 30


def test_two_talkers_are_both_found_and_counted(kemar, localiser) -> None:
    ears = talkers(kemar, [40.0, -75.0], 0.0, 1.0, seed=1)
    given = localiser.localise(ears, count=2)
    assert near([s.azimuth for s in given.sources], [40.0, -75.0])
    counted = localiser.localise(ears)
    assert len(counted.sources) == 2 and near([s.azimuth for s in counted.sources], [40.0, -75.0])
    assert all(0.0 < s.confidence <= 1.0 and 0.0 < s.weight <= 1.0 for s in counted.sources)
    assert counted.requested is None and given.requested == 2
    assert given.distribution.sum() + given.background == pytest.approx(1.0)


def test_the_louder_talker_explains_more_power(kemar, localiser) -> None:
    dry = np.stack([0.1 * speech_like(1.0, RATE, np.random.default_rng([3, k])) for k in range(2)])
    dry[1] *= 0.3
    ears = BinauralRenderer(RATE, 2, hrirs=kemar).render(dry, 0.0, [-30.0, 60.0])
    sources = {round(s.azimuth / 5) * 5: s for s in localiser.localise(ears, count=2).sources}
    assert set(sources) == {-30, 60}
    assert sources[-30].power > 2 * sources[60].power


def test_estimates_stream_every_smoothing_frames_in_the_head_frame(kemar) -> None:
    setup = LocaliserSetup(rate=RATE, smoothing=20)
    streaming = SourceLocaliser(setup, hrirs=kemar)
    ears = talkers(kemar, [100.0, -20.0], 40.0, 2.0, seed=4)
    estimates = []
    for start in range(0, len(ears), 1000):
        estimates += streaming.feed(ears[start:start + 1000], count=2)
    per_estimate = 20 * 512
    assert [e.end for e in estimates] == [k * per_estimate + 512 for k in range(1, len(estimates) + 1)]
    assert len(estimates) == (len(ears) - 512) // per_estimate and all(e.frames == 20 for e in estimates)
    # No head azimuth given: the head frame, the head at 40° in the room.
    assert all(e.head_azimuth is None and e.room_sources() is None for e in estimates)
    assert sum(near([s.azimuth for s in e.sources], [60.0, -60.0]) for e in estimates) >= len(estimates) - 1


def test_a_turn_drops_the_mirror_images_a_still_head_cannot(kemar, localiser) -> None:
    # A talker behind at 150° and one in front at 20°; the head listens from 0° then from 20°.
    ears = talkers(kemar, [150.0, 20.0], [0.0, 20.0], 1.0, seed=5)
    half = len(ears) // 2
    room = RoomAzimuthFilter()
    for piece, head in ((ears[:half], 0.0), (ears[half:], 20.0)):
        glimpses, _ = localiser.glimpses(piece)
        room.add(glimpses, head)
    assert room.still_head is None
    found = [s.azimuth for s in room.sources(2)]
    assert near(found, [150.0, 20.0])
    weights, _ = room.distribution()
    # Their mirror images across the first look's interaural axis (30°, 160°) hold next to nothing.
    for ghost in (30.0, 160.0):
        assert weights[np.abs(wrap_degrees(GRID_DEGREES - ghost)) <= 3].sum() < 0.05


def test_a_filter_folds_old_frames_and_finds_the_same_sources(kemar, localiser) -> None:
    ears = talkers(kemar, [-120.0, 35.0], [0.0, -25.0, 10.0], 1.5, seed=6)
    glimpses, centres = localiser.glimpses(ears)
    heads = np.array([0.0, -25.0, 10.0])[np.minimum(centres // (len(ears) // 3), 2)]
    whole, folding = RoomAzimuthFilter(capacity=1000), RoomAzimuthFilter(capacity=10)
    whole.add(glimpses, heads)
    for start in range(0, glimpses.frames, 7):
        part = type(glimpses)(glimpses.log_likelihood[start:start + 7], glimpses.weight[start:start + 7],
                              glimpses.power[start:start + 7])
        folding.add(part, heads[start:start + 7])
    assert folding.frames == whole.frames == glimpses.frames
    for room in (whole, folding):
        assert near([s.azimuth for s in room.sources(2)], [-120.0, 35.0])


def test_mirror_images_of_a_still_head_are_suspect() -> None:
    weights = np.zeros(360)
    weights[30], weights[150], weights[300] = 0.5, 0.2, 0.15     # 150° is 30°'s mirror for a head at 0°
    counting = SourceCounting(min_weight=0.1)
    assert [s.azimuth for s in pick_sources(weights, None, counting, still_head=0.0)] == [30.0, -60.0]
    assert [s.azimuth for s in pick_sources(weights, None, counting, still_head=None)] == [30.0, 150.0, -60.0]
    # Asked for three: the suspect comes last.
    assert [s.azimuth for s in pick_sources(weights, 3, counting, still_head=0.0)] == [30.0, -60.0, 150.0]
    assert float(mirror_image(30.0, 10.0)) == pytest.approx(170.0)


def test_a_block_without_a_full_frame_is_refused(localiser) -> None:
    with pytest.raises(LocalisationError, match="frame"):
        localiser.localise(np.zeros((100, 2)))


def test_noise_alone_is_no_source(kemar, localiser) -> None:
    """Diffuse noise looks like a source straight ahead or behind: once it is learnt, it detects nothing."""
    field = BinauralRenderer(RATE, 1, hrirs=kemar, diffuse_level=-40.0, seed=9)
    noise = field.render(np.zeros((1, round(3 * RATE))), 0.0, [0.0])
    learning = SourceLocaliser(LocaliserSetup(rate=RATE), hrirs=kemar)
    learning.learn_noise(noise[:round(RATE)])
    counted = learning.localise(noise[round(RATE):round(2 * RATE)])
    assert counted.sources == () and counted.evidence < SourceCounting().min_evidence
    asked = learning.localise(noise[round(2 * RATE):], count=1)
    assert len(asked.sources) == 1 and asked.confidence < 0.2
    # A talker 20 dB above the same field is detected, with the confidence of before.
    speech = talkers(kemar, [40.0], 0.0, 1.0, seed=2)
    found = learning.localise(speech + noise[round(2 * RATE):round(3 * RATE)])
    assert found.evidence > 0.5 and near([s.azimuth for s in found.sources[:1]], [40.0])
    assert found.confidence > 0.9


def test_tempered_evidence_keeps_the_lateral_angle_and_weighs_front_and_back() -> None:
    log_likelihood = np.float32(-0.02) * np.minimum(np.abs(wrap_degrees(GRID_DEGREES - 30.0)), 60.0) ** 2
    log_likelihood = np.maximum(log_likelihood, np.float32(-8.0))
    log_likelihood[150] = np.float32(-4.0)                   # the mirror image of 30° for a head at 0°
    mirror = np.mod(180 - np.arange(360), 360)
    assert np.array_equal(tempered(log_likelihood, 1.0), log_likelihood)
    lateral = tempered(log_likelihood, 0.0)
    assert np.allclose(lateral, lateral[mirror]) and lateral.max() == 0.0
    half = tempered(log_likelihood, 0.5)
    # Half the log-preference for 30° over 150° remains, and 30° is still the best.
    assert int(np.argmax(half)) == 30 and half[30] - half[150] == pytest.approx(2.0, abs=1e-4)


def _units(centres: np.ndarray, heads: np.ndarray, width: float) -> np.ndarray:
    """``(frames, 1, 360)`` head-frame log-likelihoods, a unit a frame, each sure of its room centre within *width*."""
    distance = np.abs(wrap_degrees(GRID_DEGREES[np.newaxis, :] - (centres - heads)[:, np.newaxis]))
    return np.maximum(-0.5 * (distance / width) ** 2, -12.0).astype(np.float32)[:, np.newaxis, :]


def test_a_spike_made_of_spread_evidence_is_no_source() -> None:
    """A room's reflections heard from several head azimuths: evidence spread over a region, no talker.

    The mixture gathers it into a spike as heavy as a quiet talker; the spike explains its units hardly
    better than its neighbours would, while a talker's units point at it alone (RoomAzimuthFilter.gain).
    These units are sharper than a room's (their gains larger): the count here asks for a gain of 4 nats.
    """
    rng = np.random.default_rng(4)
    centres = np.concatenate([np.full(300, 40.0), np.full(40, 120.0), rng.uniform(-110.0, -70.0, 60)])
    rng.shuffle(centres)
    heads = np.repeat([0.0, 30.0], len(centres) // 2)          # a look, a turn of 30 degrees, a look
    weight = np.ones((len(centres), 1))
    counting = SourceCounting(min_gain=4.0)
    room = RoomAzimuthFilter(capacity=1000, iterations=400, counting=counting)
    room.add(Glimpses(_units(centres, heads, 4.0), weight, weight.copy()), heads)
    weights, background = room.distribution()
    ungated = pick_sources(weights, None, dataclasses.replace(counting, min_gain=0.0), background=background)
    assert near([s.azimuth for s in ungated], [40.0, 120.0, -90.0], 2.0) and len(ungated) == 3, ungated
    spike = ungated[2]
    assert spike.weight > ungated[1].weight / 2 and spike.weight >= counting.min_weight
    gains = [room.gain(round(s.azimuth) % 360) for s in ungated]
    assert gains[0] > gains[1] > 3 * gains[2] and gains[1] > counting.min_gain > gains[2], gains
    # Counted: the two talkers, the quiet one too, and not the spike.
    assert [round(s.azimuth) for s in room.sources()] == [40, 120]
    # Asked for three, the filter still names it (the gain judges a count, not a request).
    assert near([s.azimuth for s in room.sources(3)][2:], [spike.azimuth], 1.0)
