"""The localiser: estimates in the head frame, streaming, head turns that resolve front and back, speed."""

from __future__ import annotations

import math
import tracemalloc

import numpy as np
import pytest

from aiogenomix.components.binaural import (
    GRID_DEGREES, AzimuthEstimate, AzimuthLikelihood, BinauralLocaliser, BinauralRenderer, FrontBackPolicy, HrirSet,
    LocalisationError, LocaliserSetup, combine_in_room, speech_like, white_noise,
)

RATE = 24_414.0


@pytest.fixture(scope="module")
def localiser(kemar: HrirSet) -> BinauralLocaliser:
    return BinauralLocaliser(LocaliserSetup(rate=RATE), hrirs=kemar)


def scene(kemar: HrirSet, dry: np.ndarray, azimuth: float, head: float, snr: float, seed: int):
    """The ears' audio of one source in a diffuse field at *snr*, and a stretch of the field alone."""
    ears = BinauralRenderer(RATE, 1, hrirs=kemar).render(dry[np.newaxis], head, [azimuth])
    field = BinauralRenderer(RATE, 0, hrirs=kemar, diffuse_level=0.0, seed=seed).render(
        np.zeros((0, 2 * len(dry))), head)
    gain = np.sqrt(np.mean(ears**2) / 10 ** (snr / 10))
    return ears + gain * field[len(dry):], gain * field[:len(dry)]


@pytest.mark.parametrize("make", [white_noise, speech_like])
def test_a_source_at_62_5_degrees_is_found_within_5_degrees(kemar, localiser, make) -> None:
    dry = 0.1 * make(1.0, RATE, np.random.default_rng(1))
    ears, noise = scene(kemar, dry, 62.5, 0.0, 10.0, seed=2)
    localiser.learn_noise(noise)
    estimate = localiser.localise(ears)
    lateral = math.degrees(math.asin(math.sin(estimate.azimuth)))
    assert abs(lateral - 62.5) <= 5.0
    assert -math.pi < estimate.azimuth <= math.pi and 0.0 <= estimate.confidence <= 1.0 + 1e-9


def test_estimates_are_in_the_head_frame(kemar, localiser) -> None:
    dry = 0.1 * white_noise(0.5, RATE, np.random.default_rng(3))
    ears, noise = scene(kemar, dry, 100.0, 40.0, 20.0, seed=4)
    localiser.learn_noise(noise)
    assert localiser.localise(ears).degrees == pytest.approx(60.0, abs=3.0)


def test_head_turns_tell_32_5_from_147_5_degrees_in_every_seeded_run(kemar, localiser) -> None:
    for seed in range(6):
        for azimuth in (32.5, 147.5):
            rng = np.random.default_rng([seed, int(azimuth)])
            head = float(rng.uniform(-10.0, 10.0))
            observations = []
            for turn in (0.0, 30.0, -30.0):
                dry = 0.1 * speech_like(0.5, RATE, rng)
                ears, noise = scene(kemar, dry, azimuth, head + turn, 5.0, seed=int(rng.integers(1 << 30)))
                localiser.learn_noise(noise)
                observations.append((localiser.localise(ears).likelihood, head + turn))
            room = combine_in_room(observations)
            assert abs(room.peak() - azimuth) < 5.0, (seed, azimuth)
            assert room.confidence() > 0.9


def test_streaming_gives_an_estimate_every_smoothing_frames(kemar) -> None:
    setup = LocaliserSetup(rate=RATE, frame=1024, hop=512, smoothing=10)
    streaming = BinauralLocaliser(setup, hrirs=kemar)
    dry = 0.1 * white_noise(2.0, RATE, np.random.default_rng(5))
    ears = BinauralRenderer(RATE, 1, hrirs=kemar).render(dry[np.newaxis], 0.0, [-45.0])
    estimates = []
    for start in range(0, len(ears), 1000):
        estimates += streaming.feed(ears[start:start + 1000])
    per_estimate = 10 * 512
    assert len(estimates) == (len(ears) - 1024 + 512) // per_estimate
    assert [e.end for e in estimates] == [k * per_estimate + 512 for k in range(1, len(estimates) + 1)]
    assert all(e.frames == 10 for e in estimates)
    # The same frames in one block give the same estimate.
    second = BinauralLocaliser(setup, hrirs=kemar).localise(ears[per_estimate:2 * per_estimate + 512])
    assert second.azimuth == pytest.approx(estimates[1].azimuth, abs=1e-9)
    assert all(abs(abs(e.degrees) - 45.0) < 5.0 for e in estimates)


def test_a_likelihood_turns_into_the_room_frame() -> None:
    head_frame = AzimuthLikelihood(-0.5 * ((GRID_DEGREES - 30.0) / 3.0) ** 2)
    assert head_frame.peak() == pytest.approx(30.0, abs=0.01)
    room = head_frame.in_room(40.5)
    assert room.frame == "room" and room.peak() == pytest.approx(70.5, abs=0.05)
    assert room.relative_to(40.5).peak() == pytest.approx(30.0, abs=0.05)
    assert head_frame.confidence() == pytest.approx(0.999, abs=0.002)
    with pytest.raises(LocalisationError):
        room.in_room(0.0)


def test_a_front_back_tie_shows_two_peaks_of_half_confidence() -> None:
    tie = AzimuthLikelihood(np.logaddexp(-0.5 * ((GRID_DEGREES - 30.0) / 2.0) ** 2,
                                         -0.5 * ((GRID_DEGREES - 150.0) / 2.0) ** 2))
    (first, first_mass), (second, second_mass) = tie.peaks(2)
    assert sorted([first, second]) == [30.0, 150.0]
    assert first_mass == pytest.approx(0.5, abs=0.01) and second_mass == pytest.approx(0.5, abs=0.01)
    assert tie.confidence() == pytest.approx(0.5, abs=0.01)


def test_setups_that_make_no_analysis_are_refused(kemar) -> None:
    with pytest.raises(LocalisationError, match="power of two"):
        BinauralLocaliser(LocaliserSetup(rate=RATE, frame=1000), hrirs=kemar)
    with pytest.raises(LocalisationError, match="frequency"):
        BinauralLocaliser(LocaliserSetup(rate=RATE, min_frequency=6000.0, max_frequency=5000.0), hrirs=kemar)
    with pytest.raises(LocalisationError, match="frame"):
        BinauralLocaliser(LocaliserSetup(rate=RATE), hrirs=kemar).localise(np.zeros((100, 2)))


def test_a_head_turning_within_an_estimate_is_accounted_for(kemar) -> None:
    # The head turns at 90°/s while the source stays at 100° in the room: each estimate of 10 frames
    # (0.21 s) spans 19° of head motion. Fed with the head azimuth of every sample, the estimates are
    # seen from the head at their last frame; without it, they smear over the turn and fall behind.
    setup = LocaliserSetup(rate=RATE, smoothing=10)
    dry = 0.1 * white_noise(2.0, RATE, np.random.default_rng(8))
    chunk = 1024
    renderer = BinauralRenderer(RATE, 1, hrirs=kemar)
    heads = -30.0 + 90.0 * np.arange(1, len(dry) + 1) / RATE
    ears = np.concatenate([renderer.render(dry[np.newaxis, s:s + chunk], heads[min(s + chunk, len(dry)) - 1],
                                           [100.0]) for s in range(0, len(dry), chunk)])
    # The renderer's head moves linearly within each chunk, as the capture's positions say.
    followed = BinauralLocaliser(setup, hrirs=kemar)
    estimates = followed.feed(ears, heads)
    blind = BinauralLocaliser(setup, hrirs=kemar).feed(ears)
    assert len(estimates) == len(blind) >= 8
    for estimate, other in zip(estimates[1:], blind[1:], strict=True):
        assert estimate.head_azimuth == pytest.approx(heads[estimate.end - 1 - 512], abs=0.01)
        truth = 100.0 - estimate.head_azimuth
        assert abs(estimate.degrees - truth) < 2.0
        assert estimate.room is not None and abs(estimate.room.peak() - 100.0) < 2.0
        assert other.head_azimuth is None and other.room is None
    behind = [abs(o.degrees - (100.0 - e.head_azimuth)) for e, o in zip(estimates[1:], blind[1:], strict=True)]
    assert np.median(behind) > 5.0


@pytest.mark.parametrize("window", ["hanning", "hamming", "blackman", "rectangular"])
def test_every_window_localises(kemar, window) -> None:
    localiser = BinauralLocaliser(LocaliserSetup(rate=RATE, window=window), hrirs=kemar)
    dry = 0.1 * white_noise(0.5, RATE, np.random.default_rng(9))
    ears, noise = scene(kemar, dry, -62.5, 0.0, 20.0, seed=10)
    localiser.learn_noise(noise)
    assert localiser.localise(ears).degrees == pytest.approx(-62.5, abs=3.0)
    with pytest.raises(LocalisationError, match="window"):
        BinauralLocaliser(LocaliserSetup(rate=RATE, window="kaiser"), hrirs=kemar)  # type: ignore[arg-type]


def test_long_estimates_of_large_frames_hold_a_few_megabytes(kemar) -> None:
    # A large analysis a client may ask binauloc for: 200 frames' spectra of 8158 bins an estimate, 52 MB
    # if kept until the estimate, as much again to stack them. As they arrive, they are summed instead.
    setup = LocaliserSetup(rate=48_000.0, max_frequency=24_000.0, frame=16_384, hop=16_384, smoothing=200)
    localiser = BinauralLocaliser(setup, hrirs=kemar)
    rng = np.random.default_rng(11)
    block = 48_000
    blocks = -(-setup.frame * setup.smoothing // block)
    heads = np.linspace(0.0, 100.0, blocks * block)  # a turning head: a run of frames per degree
    tracemalloc.start()
    try:
        learner = localiser.noise_learner()
        for _ in range(30):  # half a minute of noise: held as sums, not as audio
            learner.feed(0.01 * rng.standard_normal((block, 2)))
        learner.learnt()
        estimates = []
        for k in range(blocks):
            estimates += localiser.feed(0.1 * rng.standard_normal((block, 2)), heads[k * block:(k + 1) * block])
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert learner.frames == 30 * block // setup.hop
    assert len(estimates) == 1 and estimates[0].frames == 200
    assert peak < 32 << 20, f"{peak / 2**20:.0f} MiB"


def test_looks_near_a_limit_never_ask_twice_for_one_azimuth() -> None:
    # The head starts at 70° (limits ±89.5°), the source on its left: the first look there (100°) is beyond the
    # limit, so the looks go the other way, each from an azimuth not looked from before.
    policy = FrontBackPolicy(turn=30.0, limits=(-89.5, 89.5), max_turns=4)
    flat = AzimuthLikelihood(np.zeros(len(GRID_DEGREES)), "head")  # nothing learnt: never settled by confidence
    policy.add(AzimuthEstimate(math.radians(30.0), 0.1, flat, 10, 1, head_azimuth=70.0))
    policy.looked(70.0)
    looks = []
    while (target := policy.next_look()) is not None:
        looks.append(target)
        policy.looked(target)
    assert looks == [40.0, 10.0, -20.0, -50.0]
