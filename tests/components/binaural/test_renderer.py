"""The streaming renderer against the HRIRs themselves: cues, clicks, the diffuse field, noise, speed."""

from __future__ import annotations

import numpy as np
import pytest

from aiogenomix.components.binaural import (
    BinauralRenderer, HrirError, HrirSet, band_ilds, diffuse_filters, gcc_phat_itd, third_octave_centres,
)

RATE = 44_100.0


def render_in_chunks(renderer: BinauralRenderer, dry: np.ndarray, heads, azimuths, chunk: int) -> np.ndarray:
    pieces = []
    for index, start in enumerate(range(0, dry.shape[1], chunk)):
        head = heads(index) if callable(heads) else heads
        pieces.append(renderer.render(dry[:, start:start + chunk], head, azimuths))
    return np.concatenate(pieces)


@pytest.mark.parametrize("head", [0.0, 40.0])
@pytest.mark.parametrize("relative", [30.0, 75.0, 120.0, 150.0])
def test_rendered_itd_and_ilds_are_kemars(kemar: HrirSet, head: float, relative: float) -> None:
    noise = np.random.default_rng(int(relative + head)).standard_normal((1, int(RATE)))
    ears = render_in_chunks(BinauralRenderer(RATE, 1, hrirs=kemar), noise, head, [head + relative], 4410)[1024:]
    measured = kemar.taps[kemar.index(relative)]
    assert abs(gcc_phat_itd(*ears.T, max_lag=50) - gcc_phat_itd(*measured.T, max_lag=50)) <= 1.0
    difference = band_ilds(*ears.T, RATE) - band_ilds(*measured.T, RATE)
    assert np.sqrt(np.mean(difference**2)) <= 2.0


def test_at_24414_hz_the_cues_are_those_of_the_resampled_set(kemar: HrirSet) -> None:
    rate = 24_414.0
    noise = np.random.default_rng(3).standard_normal((1, int(rate)))
    ears = render_in_chunks(BinauralRenderer(rate, 1, hrirs=kemar), noise, 0.0, [75.0], 4096)[1024:]
    measured = kemar.taps[kemar.index(75.0)]
    assert gcc_phat_itd(*ears.T, max_lag=30) == pytest.approx(gcc_phat_itd(*measured.T, max_lag=50) * rate / RATE,
                                                              abs=1.0)
    centres = third_octave_centres(200.0, 10_000.0)
    difference = band_ilds(*ears.T, rate, centres) - band_ilds(*measured.T, RATE, centres)
    assert np.sqrt(np.mean(difference**2)) <= 2.0


def largest_jump(ears: np.ndarray) -> float:
    return float(np.max(np.abs(np.diff(ears, axis=0))))


def test_a_head_sweep_has_no_click(kemar: HrirSet) -> None:
    # A low tone changes little from sample to sample, so that a jump in the filters would stand out:
    # the head turns at 180°/s, 4° per chunk of 1024 frames, past a source on its left.
    chunk, chunks = 1024, 40
    t = np.arange(chunk * chunks) / RATE
    tone = 0.5 * np.sin(2 * np.pi * 125.0 * t)[np.newaxis]
    heads = np.arange(1, chunks + 1) * 180.0 * chunk / RATE
    sweep = render_in_chunks(BinauralRenderer(RATE, 1, hrirs=kemar), tone, lambda i: heads[i], [60.0], chunk)
    statics = {}
    for head in np.concatenate([[0.0], heads]):
        statics[head] = render_in_chunks(BinauralRenderer(RATE, 1, hrirs=kemar), tone, head, [60.0], chunk)
    skip = 1024   # the filters' start-up
    bound = 1.1 * max(largest_jump(ears[skip:]) for ears in statics.values())
    assert largest_jump(sweep[skip:]) <= bound
    # The same sweep with the filters switched at the chunks' edges, not cross-faded, clicks.
    switched = np.concatenate([statics[heads[i]][i * chunk:(i + 1) * chunk] for i in range(chunks)])
    assert largest_jump(switched[skip:]) > 1.5 * bound


def test_chunking_does_not_change_a_still_scene(kemar: HrirSet) -> None:
    dry = np.random.default_rng(5).standard_normal((2, 20_000))
    one = BinauralRenderer(RATE, 2, hrirs=kemar).render(dry, 10.0, [30.0, -100.0])
    many = render_in_chunks(BinauralRenderer(RATE, 2, hrirs=kemar), dry, 10.0, [30.0, -100.0], 777)
    assert np.allclose(one, many, atol=1e-12)


def test_sources_add_up_at_their_levels(kemar: HrirSet) -> None:
    rng = np.random.default_rng(6)
    dry = rng.standard_normal((2, 8000)) * np.array([[0.1], [0.01]])
    both = BinauralRenderer(RATE, 2, hrirs=kemar).render(dry, 5.0, [30.0, -120.0])
    first = BinauralRenderer(RATE, 1, hrirs=kemar).render(dry[:1], 5.0, [30.0])
    second = BinauralRenderer(RATE, 1, hrirs=kemar).render(dry[1:], 5.0, [-120.0])
    assert np.allclose(both, first + second, atol=1e-12)
    assert np.sqrt(np.mean(second**2)) == pytest.approx(0.01 * np.sqrt(np.mean(first**2)) / 0.1, rel=0.5)


def test_a_source_ahead_keeps_its_level(kemar: HrirSet) -> None:
    dry = 0.1 * np.random.default_rng(7).standard_normal((1, 44_100))
    ears = BinauralRenderer(RATE, 1, hrirs=kemar).render(dry, 0.0, [0.0])[1024:]
    assert 20 * np.log10(np.sqrt(np.mean(ears**2)) / 0.1) == pytest.approx(0.0, abs=0.3)


def band_powers(x: np.ndarray, rate: float, centres: np.ndarray) -> np.ndarray:
    spectrum = np.abs(np.fft.rfft(x)) ** 2
    freqs = np.fft.rfftfreq(len(x), 1 / rate)
    return np.array([spectrum[(freqs >= c * 10**-0.05) & (freqs < c * 10**0.05)].sum() for c in centres])


def band_coherence(left: np.ndarray, right: np.ndarray, rate: float, centres: np.ndarray) -> np.ndarray:
    frames = np.lib.stride_tricks.sliding_window_view(np.stack([left, right]), 1024, axis=1)[:, ::512]
    spectra = np.fft.rfft(frames * np.hanning(1024), axis=-1)
    cross = np.mean(spectra[0] * np.conj(spectra[1]), axis=0)
    powers = np.mean(np.abs(spectra) ** 2, axis=1)
    freqs = np.fft.rfftfreq(1024, 1 / rate)
    result = []
    for c in centres:
        band = (freqs >= c * 10**-0.05) & (freqs < c * 10**0.05)
        result.append(np.real(cross[band].sum()) / np.sqrt(powers[0, band].sum() * powers[1, band].sum()))
    return np.array(result)


def test_the_diffuse_field_is_72_uncorrelated_noises_through_the_hrirs(kemar: HrirSet) -> None:
    rate = 24_414.0
    frames = int(4 * rate)
    field = BinauralRenderer(rate, 0, hrirs=kemar, diffuse_level=-20.0, seed=1).render(np.zeros((0, frames)), 0.0)
    azimuths = np.arange(-180.0, 180.0, 5.0)
    noises = np.random.default_rng(2).standard_normal((72, frames)) * 0.1 / np.sqrt(72)
    brute = BinauralRenderer(rate, 72, hrirs=kemar).render(noises, 0.0, azimuths)
    brute *= np.sqrt(np.mean(field[2048:] ** 2) / np.mean(brute[2048:] ** 2))   # compare shapes, not the scale
    field, brute = field[2048:], brute[2048:]
    centres = third_octave_centres(200.0, 8000.0)
    for ear in range(2):
        ratio = band_powers(field[:, ear], rate, centres) / band_powers(brute[:, ear], rate, centres)
        difference = 10 * np.log10(ratio)
        assert np.max(np.abs(difference)) < 1.5
    coherence = band_coherence(*field.T, rate, centres)
    assert np.max(np.abs(coherence - band_coherence(*brute.T, rate, centres))) < 0.1
    # A diffuse field is coherent at the ears at low frequencies only.
    assert coherence[0] > 0.4 and np.max(np.abs(coherence[centres > 2000])) < 0.2


def test_the_diffuse_field_and_sensor_noise_have_their_levels(kemar: HrirSet) -> None:
    rate = 24_414.0
    field = BinauralRenderer(rate, 0, hrirs=kemar, diffuse_level=-30.0, seed=3).render(np.zeros((0, 100_000)), 0.0)
    assert 10 * np.log10(np.mean(field[2048:] ** 2)) == pytest.approx(-30.0, abs=0.2)
    sensor = BinauralRenderer(rate, 0, hrirs=kemar, sensor_noise=-60.0, seed=3).render(np.zeros((0, 100_000)), 0.0)
    assert 10 * np.log10(np.mean(sensor**2, axis=0)) == pytest.approx([-60.0, -60.0], abs=0.1)
    assert abs(np.corrcoef(sensor.T)[0, 1]) < 0.02
    assert diffuse_filters(kemar, rate) is diffuse_filters(kemar, rate)


def test_the_first_block_needs_the_sources_azimuths(kemar: HrirSet) -> None:
    renderer = BinauralRenderer(RATE, 1, hrirs=kemar)
    with pytest.raises(HrirError, match="azimuths"):
        renderer.render(np.zeros((1, 10)), 0.0)
    with pytest.raises(HrirError, match=r"\(1, frames\)"):
        renderer.render(np.zeros((2, 10)), 0.0, [0.0])


# Speed (10× real time or more on one core) is met in a benchmark, not here: ./run bench --only localisation.
