"""The room renderer's shortcuts give what they stand for: the late convolver a plain convolution, the early
reflections of a room absorbing per band the responses of its seven bands, summed, and responses made again in
part as a head turns the responses made afresh.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from aiogenomix.components.binaural import HrirSet, RoomRenderer, Shoebox, band_weights
from aiogenomix.components.binaural._convolution import StagedLateConvolver
from aiogenomix.components.binaural._directions import NearestDirections
from aiogenomix.components.binaural._early import _SourceImages


def test_the_late_convolver_is_a_convolution_whatever_the_calls_sizes() -> None:
    rng = np.random.default_rng(1)
    tails = rng.standard_normal((3, 20_000, 2))
    tails[:, :1024] = 0.0                                # silent for its first block, as a late tail is
    late = StagedLateConvolver(tails, 1024)
    dry = rng.standard_normal((3, 30_000))
    cuts = [0, 1, 700, 2205, 5000, 9000, 9001, 30_000]   # calls shorter and longer than every stage's block
    out = np.concatenate([late.convolve(dry[:, a:b]) for a, b in zip(cuts[:-1], cuts[1:], strict=True)])
    expected = sum(np.stack([signal.fftconvolve(dry[i], tails[i, :, ear])[:30_000] for ear in range(2)], axis=1)
                   for i in range(3))
    assert np.max(np.abs(out - expected)) < 1e-9 * np.max(np.abs(expected))


@pytest.mark.parametrize("absorption", [
    {"walls": [0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6], "floor": [0.02, 0.05, 0.1, 0.2, 0.3, 0.35, 0.4], "ceiling": 0.5},
    [0.3, 0.25, 0.2, 0.18, 0.15, 0.12, 0.1],           # alike on every wall: one response per order
], ids=["per wall and band", "per band"])
def test_a_room_absorbing_per_band_has_the_early_responses_of_its_seven_bands(kemar: HrirSet,
                                                                               absorption: object) -> None:
    room = Shoebox.with_absorption((6.0, 4.0, 3.0), absorption)  # type: ignore[arg-type]
    listener = np.array([3.2, 1.9, 1.5])
    positions = np.array([[1.0, 1.0, 1.2], [5.1, 3.0, 1.7]])
    renderer = RoomRenderer(44_100, 2, hrirs=kemar, room=room, mixing_time=0.06)
    renderer.render(np.zeros((2, 64)), 20.0, positions, listener)
    early = renderer.early
    assert early is not None
    made = early.spectra(positions, listener, 20.0)
    # Each band's responses on their own, weighted by the band's share of every frequency, then summed.
    weights = band_weights(np.fft.rfftfreq(early.convolver.n_fft, 1.0 / 44_100))
    expected = early.tail_head.copy()
    for s, position in enumerate(positions):
        images = _SourceImages.of(early, position, listener)
        nearest = NearestDirections(renderer.hrirs).indices(images.azimuth - 20.0, images.elevation)
        for band in range(7):
            response = np.zeros((2, early.length))
            for start, gain, direction in zip(images.starts, images.gains[:, band], nearest, strict=True):
                response[:, start:start + early._taps.shape[2]] += gain * early._taps[direction]
            expected[s] += weights[band] * np.fft.rfft(response, early.convolver.n_fft, axis=-1)
    assert np.max(np.abs(made - expected)) < 1e-10 * np.max(np.abs(expected))
    assert len(images.starts) > 50                      # orders 1 to 3 within 60 ms: the bands have their images


@pytest.mark.parametrize("rt60", [0.5, [0.7, 0.6, 0.55, 0.5, 0.45, 0.4, 0.35]], ids=["one RT60", "per band"])
def test_a_turning_head_remakes_only_changed_responses_and_they_are_those_made_afresh(kemar: HrirSet,
                                                                                   rt60: object) -> None:
    room = Shoebox.with_rt60((6.0, 4.0, 3.0), rt60)  # type: ignore[arg-type]
    listener = np.array([3.0, 2.0, 1.5])
    positions = np.array([[4.3, 2.75, 1.5], [2.65, 0.03, 1.5], [0.83, 3.25, 1.5]])
    renderer = RoomRenderer(44_100, 3, hrirs=kemar, room=room)
    partial = 0
    for head in np.arange(0.0, 12.0, 0.75):          # a block an update; under a measurement's spacing a step
        renderer.render(np.zeros((3, 2205)), float(head), positions, listener)
        early = renderer.early
        assert early is not None and early._made_with is not None
        plan, nearest, rows = early._made_with
        before = NearestDirections(renderer.hrirs).indices(plan.azimuth - (head - 0.75), plan.elevation)
        changed = set(plan.rows[(nearest != before)[plan.images]].tolist())
        partial += 0 < len(changed) < len(rows)
        fresh = early.spectra(positions, listener, float(head))
        assert np.max(np.abs(early._spectra - fresh)) < 1e-12 * np.max(np.abs(fresh))
    assert partial >= 3                                 # responses were made again in part, not only afresh
